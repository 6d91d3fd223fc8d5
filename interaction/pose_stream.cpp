#include "interaction/pose_stream.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <utility>

#include "sim/input_error.h"

namespace pliant {
namespace {

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

double parse_number(const std::string& field, const std::string& where, const char* name) {
  const std::string f = trim(field);
  char* end = nullptr;
  errno = 0;
  const double v = f.empty() ? 0.0 : std::strtod(f.c_str(), &end);
  if (f.empty() || end != f.c_str() + f.size()) {
    throw InputError(InputErrorKind::syntax, where, std::string(name) + ": expected a number, got '" + f + "'");
  }
  if (!std::isfinite(v)) throw InputError(InputErrorKind::non_finite, where, std::string(name) + ": not finite");
  return v;
}

}  // namespace

bool parse_pose_line(const std::string& line, const std::string& where, std::string& instrument,
                     PoseSample& sample, double last_jaw) {
  const std::string text = trim(line);
  if (text.empty() || text[0] == '#') return false;
  std::vector<std::string> fields;
  std::stringstream in(text);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!text.empty() && text.back() == ',') fields.emplace_back();
  if (fields.size() != 9 && fields.size() != 10) {
    throw InputError(InputErrorKind::syntax, where,
                     "expected t,instrument,x,y,z,qw,qx,qy,qz[,jaw] (9 or 10 fields), got " +
                         std::to_string(fields.size()));
  }
  sample.time = parse_number(fields[0], where, "t");
  instrument = trim(fields[1]);
  if (instrument.empty()) throw InputError(InputErrorKind::syntax, where, "instrument: empty name");
  const Vec3 x(parse_number(fields[2], where, "x"), parse_number(fields[3], where, "y"),
               parse_number(fields[4], where, "z"));
  Quat q(parse_number(fields[5], where, "qw"), parse_number(fields[6], where, "qx"),
         parse_number(fields[7], where, "qy"), parse_number(fields[8], where, "qz"));
  const double n = q.norm();
  if (!(n > 1e-12)) throw InputError(InputErrorKind::bad_value, where, "orientation quaternion is zero");
  // Already-unit quaternions are kept bit for bit, so a recorded stream replays exactly.
  if (std::abs(n - 1.0) > 1e-9) q.coeffs() /= n;
  sample.command.pose.translation = x;
  sample.command.pose.rotation = q;
  sample.command.jaw_opening = fields.size() == 10 ? parse_number(fields[9], where, "jaw") : last_jaw;
  return true;
}

std::string format_pose_line(double t, const std::string& instrument, const InstrumentCommand& cmd) {
  char buffer[512];
  const Vec3& x = cmd.pose.translation;
  const Quat& q = cmd.pose.rotation;
  std::snprintf(buffer, sizeof buffer, "%.17g,%s,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", t,
                instrument.c_str(), x.x(), x.y(), x.z(), q.w(), q.x(), q.y(), q.z(), cmd.jaw_opening);
  return buffer;
}

InstrumentCommand interpolate(const InstrumentCommand& a, const InstrumentCommand& b, double u) {
  InstrumentCommand c;
  c.pose.translation = a.pose.translation + u * (b.pose.translation - a.pose.translation);
  c.pose.rotation = a.pose.rotation.slerp(u, b.pose.rotation);
  c.jaw_opening = a.jaw_opening + u * (b.jaw_opening - a.jaw_opening);
  return c;
}

std::shared_ptr<PoseStream> PoseStream::open(const std::string& spec) {
  std::shared_ptr<PoseStream> s(new PoseStream());
  if (spec == "stdin" || spec == "-") {
    s->kind_ = Kind::stdin_stream;
    s->source_ = "stdin";
    s->fd_ = 0;
    return s;
  }
  if (spec.rfind("udp:", 0) == 0) {
    s->kind_ = Kind::udp;
    char* end = nullptr;
    const long port = std::strtol(spec.c_str() + 4, &end, 10);
    if (end == spec.c_str() + 4 || *end != '\0' || port < 0 || port > 65535) {
      throw InputError(InputErrorKind::bad_value, spec, "expected udp:PORT with PORT in [0, 65535]");
    }
    s->fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    if (s->fd_ < 0) throw InputError(InputErrorKind::io, spec, std::string("socket: ") + std::strerror(errno));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(s->fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      throw InputError(InputErrorKind::io, spec, std::string("bind: ") + std::strerror(errno));
    }
    socklen_t len = sizeof addr;
    ::getsockname(s->fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    s->port_ = ntohs(addr.sin_port);
    ::fcntl(s->fd_, F_SETFL, ::fcntl(s->fd_, F_GETFL) | O_NONBLOCK);
    s->source_ = "udp:" + std::to_string(s->port_);
    return s;
  }
  const std::string path = spec.rfind("file:", 0) == 0 ? spec.substr(5) : spec;
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(InputErrorKind::io, path, "cannot open pose stream file");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return from_text(buffer.str(), path);
}

std::shared_ptr<PoseStream> PoseStream::from_text(const std::string& text, const std::string& source) {
  std::shared_ptr<PoseStream> s(new PoseStream());
  s->kind_ = Kind::file;
  s->source_ = source;
  s->add_text(text);
  if (!s->partial_.empty()) s->add_line(std::exchange(s->partial_, std::string()));
  s->ended_ = true;
  return s;
}

PoseStream::~PoseStream() {
  if (kind_ == Kind::udp && fd_ >= 0) ::close(fd_);  // stdin is not ours to close
}

void PoseStream::add_text(const std::string& text) {
  partial_ += text;
  size_t start = 0;
  for (size_t nl = partial_.find('\n'); nl != std::string::npos; nl = partial_.find('\n', start)) {
    add_line(partial_.substr(start, nl - start));
    start = nl + 1;
  }
  partial_.erase(0, start);
}

void PoseStream::add_line(const std::string& line) {
  ++line_number_;
  const std::string where = file_line(source_, line_number_);
  std::string instrument;
  PoseSample sample;
  // The jaw column defaults to the instrument's last value; the name is needed first.
  const auto comma1 = line.find(',');
  const auto comma2 = comma1 == std::string::npos ? comma1 : line.find(',', comma1 + 1);
  double last_jaw = 0.0;
  if (comma2 != std::string::npos) {
    const auto it = last_jaw_.find(trim(line.substr(comma1 + 1, comma2 - comma1 - 1)));
    if (it != last_jaw_.end()) last_jaw = it->second;
  }
  if (!parse_pose_line(line, where, instrument, sample, last_jaw)) return;
  auto& list = samples_[instrument];
  if (kind_ == Kind::file && !list.empty() && !(sample.time > list.back().time)) {
    throw InputError(InputErrorKind::bad_value, where,
                     "times must increase per instrument (t = " + trim(line.substr(0, comma1)) +
                         " is not after the previous sample of '" + instrument + "')");
  }
  last_jaw_[instrument] = sample.command.jaw_opening;
  list.push_back(sample);
}

void PoseStream::poll() {
  if (kind_ == Kind::file || ended_) return;
  char buffer[65536];
  if (kind_ == Kind::udp) {
    for (;;) {
      const ssize_t n = ::recv(fd_, buffer, sizeof buffer, 0);
      if (n < 0) break;  // EAGAIN: nothing more for now
      add_text(std::string(buffer, static_cast<size_t>(n)));
      // A datagram ends its last line.
      if (!partial_.empty()) add_line(std::exchange(partial_, std::string()));
    }
    return;
  }
  // stdin: read only what poll() says is there, never block.
  for (;;) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 0) <= 0 || (p.revents & (POLLIN | POLLHUP)) == 0) return;
    const ssize_t n = ::read(fd_, buffer, sizeof buffer);
    if (n <= 0) {
      if (!partial_.empty()) add_line(std::exchange(partial_, std::string()));
      ended_ = true;
      return;
    }
    add_text(std::string(buffer, static_cast<size_t>(n)));
  }
}

const std::vector<PoseSample>& PoseStream::samples(const std::string& instrument) const {
  static const std::vector<PoseSample> kNone;
  const auto it = samples_.find(instrument);
  return it == samples_.end() ? kNone : it->second;
}

StreamPoseSource::StreamPoseSource(std::shared_ptr<PoseStream> stream, std::string instrument,
                                   const InstrumentCommand& initial)
    : stream_(std::move(stream)), instrument_(std::move(instrument)), initial_(initial) {}

InstrumentCommand StreamPoseSource::sample(double t, const InstrumentFeedback&) {
  stream_->poll();
  const auto& s = stream_->samples(instrument_);
  if (s.empty()) return initial_;
  if (stream_->kind() != PoseStream::Kind::file) return s.back().command;
  // Recorded: interpolate between the samples around t (t does not decrease: move a cursor).
  while (cursor_ + 1 < s.size() && s[cursor_ + 1].time <= t) ++cursor_;
  const PoseSample& a = s[cursor_];
  if (t <= a.time || cursor_ + 1 == s.size()) return a.command;
  const PoseSample& b = s[cursor_ + 1];
  return interpolate(a.command, b.command, (t - a.time) / (b.time - a.time));
}

bool StreamPoseSource::finished(double t) const {
  if (stream_->kind() != PoseStream::Kind::file) return stream_->ended();
  const auto& s = stream_->samples(instrument_);
  return s.empty() || t >= s.back().time;
}

}  // namespace pliant
