// Load-time errors (STYLE.md tier 3): bad meshes, scenes, scripts and flags. Each names where the
// problem is (file and line, or JSON path) and what was expected. Never thrown inside a step.
#pragma once

#include <stdexcept>
#include <string>

namespace pliant {

/// What kind of bad input was found; tests assert on it.
enum class InputErrorKind {
  io,                  ///< file missing, unreadable, or unwritable
  syntax,              ///< text that does not parse (bad number, bad JSON, unexpected token)
  truncated,           ///< the input ended before what its header promised
  count_mismatch,      ///< a count in a header disagrees with the data
  index_out_of_range,  ///< an element refers to a vertex that does not exist
  non_finite,          ///< NaN or infinite coordinate or value
  degenerate_element,  ///< zero or near-zero volume tetrahedron
  unknown_key,         ///< a JSON key or section that is not part of the format
  wrong_type,          ///< a JSON value of the wrong type
  bad_value,           ///< a value of the right type outside its allowed range
  unsupported,         ///< a valid but unsupported format feature (e.g. binary .msh)
  topology,            ///< non-manifold or otherwise broken mesh topology
};

/// Short name of an error kind, e.g. "index_out_of_range".
const char* to_string(InputErrorKind kind);

/// Bad input found at load time. what() reads "<where>: <message>", e.g.
/// "mesh.ele:7: tetrahedron 3 refers to vertex 12, but there are 10 vertices" or
/// "scene.json: /bodies/1/material/young_modulus: expected a positive number, got -3".
class InputError : public std::runtime_error {
 public:
  InputError(InputErrorKind kind, std::string where, const std::string& message)
      : std::runtime_error(where.empty() ? message : where + ": " + message),
        kind_(kind),
        where_(std::move(where)) {}

  InputErrorKind kind() const { return kind_; }
  /// "file:line", "file: /json/path" or "" when the input has no name.
  const std::string& where() const { return where_; }

 private:
  InputErrorKind kind_;
  std::string where_;
};

/// "file:line" for text formats (line counted from 1).
inline std::string file_line(const std::string& file, long line) {
  return file + ":" + std::to_string(line);
}

}  // namespace pliant
