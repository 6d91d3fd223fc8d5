// Streamed instrument poses (issue 6, item 4): a recorded file, stdin, or a UDP socket on loopback.
//
// Line format (CSV, one pose per line, SI units, '#' starts a comment line, blank lines skipped):
//   t,instrument,x,y,z,qw,qx,qy,qz[,jaw]
//   t: s (strictly increasing per instrument in a file); x,y,z: m; q: orientation (normalised on
//   read, must not be zero); jaw: opening angle in rad (default: the last value, initially 0).
// Playback:
//   file: read whole at open; between two samples the pose is interpolated (lerp for position and
//         jaw, slerp for rotation); exact at sample times; the first sample before it, the last after.
//   stdin / udp: live; whatever has arrived is read without blocking at each sample() and the
//         latest sample of the instrument is used (zero-order hold; its t is not compared with
//         simulated time, device clocks differ).
// Bad lines throw InputError naming "source:line" (source = file path, "stdin" or "udp:PORT").
//
// API:
//   auto stream = PoseStream::open("file:poses.csv" | "poses.csv" | "stdin" | "-" | "udp:9000");
//   StreamPoseSource src(stream, "probe", initial_command);
//   std::string line = format_pose_line(t, "probe", cmd);   // to record what a source produced
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "interaction/pose_source.h"

namespace pliant {

/// One timestamped pose of one instrument.
struct PoseSample {
  double time = 0.0;  ///< s
  InstrumentCommand command;
};

/// Parses one line; returns false for blank/comment lines. Throws InputError naming `where`.
/// `last_jaw` supplies the jaw opening when the column is missing.
bool parse_pose_line(const std::string& line, const std::string& where, std::string& instrument,
                     PoseSample& sample, double last_jaw = 0.0);
/// Formats a line that parses back to exactly the same numbers (17 significant digits).
std::string format_pose_line(double t, const std::string& instrument, const InstrumentCommand& cmd);

/// A source of pose lines shared by the StreamPoseSources of several instruments.
class PoseStream {
 public:
  enum class Kind { file, stdin_stream, udp };
  /// Opens "file:PATH" (or a bare PATH), "stdin" / "-", or "udp:PORT" (binds 127.0.0.1:PORT).
  /// Throws InputError (io) if it cannot; a file's bad lines throw at open.
  static std::shared_ptr<PoseStream> open(const std::string& spec);
  /// A stream over text already in memory (tests); behaves like a file named `source`.
  static std::shared_ptr<PoseStream> from_text(const std::string& text, const std::string& source);
  ~PoseStream();
  PoseStream(const PoseStream&) = delete;
  PoseStream& operator=(const PoseStream&) = delete;

  Kind kind() const { return kind_; }
  const std::string& source() const { return source_; }
  /// Reads whatever has arrived (live streams; no-op for files). Throws InputError on a bad line.
  void poll();
  /// All samples of an instrument received so far, in order.
  const std::vector<PoseSample>& samples(const std::string& instrument) const;
  /// True if the live stream reached end of input (stdin closed); files are always complete.
  bool ended() const { return ended_; }
  /// UDP port actually bound (useful with "udp:0").
  int port() const { return port_; }

 private:
  PoseStream() = default;
  void add_text(const std::string& text);  // splits complete lines, keeps a partial tail
  void add_line(const std::string& line);

  Kind kind_ = Kind::file;
  std::string source_;
  long line_number_ = 0;
  std::string partial_;
  std::map<std::string, std::vector<PoseSample>> samples_;
  std::map<std::string, double> last_jaw_;
  int fd_ = -1;
  int port_ = 0;
  bool ended_ = false;
};

/// A PoseSource reading one instrument's poses from a PoseStream.
class StreamPoseSource final : public PoseSource {
 public:
  /// `initial` is used until the stream has a sample for the instrument.
  StreamPoseSource(std::shared_ptr<PoseStream> stream, std::string instrument, const InstrumentCommand& initial);
  const std::string& instrument() const override { return instrument_; }
  InstrumentCommand sample(double t, const InstrumentFeedback& fb) override;
  bool finished(double t) const override;

 private:
  std::shared_ptr<PoseStream> stream_;
  std::string instrument_;
  InstrumentCommand initial_;
  size_t cursor_ = 0;  ///< file playback: index of the last sample with time <= t
};

/// Interpolates between two commands: lerp position and jaw, slerp rotation; u in [0, 1].
InstrumentCommand interpolate(const InstrumentCommand& a, const InstrumentCommand& b, double u);

}  // namespace pliant
