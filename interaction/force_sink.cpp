#include "interaction/force_sink.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "sim/input_error.h"

namespace pliant {

std::string format_force_line(double t, const std::string& instrument, const Vec3& f, const Vec3& tq) {
  char buffer[512];
  std::snprintf(buffer, sizeof buffer, "%.17g,%s,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g", t, instrument.c_str(),
                f.x(), f.y(), f.z(), tq.x(), tq.y(), tq.z());
  return buffer;
}

std::unique_ptr<ForceSink> ForceSink::open(const std::string& spec) {
  std::unique_ptr<ForceSink> s(new ForceSink());
  if (spec == "stdout" || spec == "-") {
    s->kind_ = Kind::stdout_stream;
    s->file_ = stdout;
    return s;
  }
  if (spec.rfind("udp:", 0) == 0) {
    s->kind_ = Kind::udp;
    char* end = nullptr;
    const long port = std::strtol(spec.c_str() + 4, &end, 10);
    if (end == spec.c_str() + 4 || *end != '\0' || port <= 0 || port > 65535) {
      throw InputError(InputErrorKind::bad_value, spec, "expected udp:PORT with PORT in [1, 65535]");
    }
    s->fd_ = ::socket(AF_INET, SOCK_DGRAM, 0);
    if (s->fd_ < 0) throw InputError(InputErrorKind::io, spec, std::string("socket: ") + std::strerror(errno));
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(s->fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      throw InputError(InputErrorKind::io, spec, std::string("connect: ") + std::strerror(errno));
    }
    s->port_ = static_cast<int>(port);
    return s;
  }
  const std::string path = spec.rfind("file:", 0) == 0 ? spec.substr(5) : spec;
  s->file_ = std::fopen(path.c_str(), "w");
  if (s->file_ == nullptr) throw InputError(InputErrorKind::io, path, "cannot open force output file");
  s->owns_file_ = true;
  std::fputs("t,instrument,fx,fy,fz,tx,ty,tz\n", s->file_);
  return s;
}

ForceSink::~ForceSink() {
  if (owns_file_ && file_ != nullptr) std::fclose(file_);
  if (fd_ >= 0) ::close(fd_);
}

void ForceSink::write(double t, const std::string& instrument, const Vec3& force, const Vec3& torque) {
  const std::string line = format_force_line(t, instrument, force, torque);
  if (kind_ == Kind::udp) {
    if (::send(fd_, line.data(), line.size(), MSG_DONTWAIT) < 0) ++dropped_;
    return;
  }
  std::fputs(line.c_str(), file_);
  std::fputc('\n', file_);
}

void ForceSink::flush() {
  if (file_ != nullptr) std::fflush(file_);
}

}  // namespace pliant
