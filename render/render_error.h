// Errors of the render module: the off-screen context cannot be created, an image cannot be
// written or read. A std::runtime_error with a message that says what failed and why.
#pragma once

#include <stdexcept>
#include <string>

namespace pliant {

/// Something the renderer or the frame output could not do (no OSMesa context, unwritable file).
class RenderError : public std::runtime_error {
 public:
  explicit RenderError(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace pliant
