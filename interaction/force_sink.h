// Instrument forces out (issue 6, item 4): CSV lines "t,instrument,fx,fy,fz,tx,ty,tz"
// (s, N, N m; 17 significant digits) to a file, stdout, or UDP datagrams to 127.0.0.1:PORT
// (one line per datagram).
//
// API: auto sink = ForceSink::open("file:forces.csv" | "forces.csv" | "stdout" | "-" | "udp:9001");
//      sink->write(t, "probe", force, torque);
#pragma once

#include <cstdio>
#include <memory>
#include <string>

#include "sim/math_types.h"

namespace pliant {

/// Formats one force line (no newline).
std::string format_force_line(double t, const std::string& instrument, const Vec3& force, const Vec3& torque);

/// Where instrument forces go.
class ForceSink {
 public:
  enum class Kind { file, stdout_stream, udp };
  /// Opens a sink; throws InputError (io) if it cannot. A file gets a header line
  /// "t,instrument,fx,fy,fz,tx,ty,tz"; stdout and UDP do not.
  static std::unique_ptr<ForceSink> open(const std::string& spec);
  ~ForceSink();
  ForceSink(const ForceSink&) = delete;
  ForceSink& operator=(const ForceSink&) = delete;

  /// Writes one line (N, N m). Never throws on a full socket buffer (the line is dropped and counted).
  void write(double t, const std::string& instrument, const Vec3& force, const Vec3& torque);
  void flush();
  Kind kind() const { return kind_; }
  /// Lines that could not be sent (UDP only).
  long dropped() const { return dropped_; }

 private:
  ForceSink() = default;
  Kind kind_ = Kind::file;
  std::FILE* file_ = nullptr;
  bool owns_file_ = false;
  int fd_ = -1;
  int port_ = 0;
  long dropped_ = 0;
};

}  // namespace pliant
