#include "interaction/host_steal.h"

#include <unistd.h>

#include <charconv>
#include <fstream>
#include <sstream>

namespace pliant {

std::optional<long long> parse_proc_stat_steal_ticks(std::string_view proc_stat) {
  // The aggregate line is "cpu  user nice system idle iowait irq softirq steal [guest guest_nice]".
  const std::string_view prefix = "cpu ";
  size_t pos = 0;
  while (pos < proc_stat.size() && proc_stat.compare(pos, prefix.size(), prefix) != 0) {
    const size_t next = proc_stat.find('\n', pos);
    if (next == std::string_view::npos) return std::nullopt;
    pos = next + 1;
  }
  if (pos >= proc_stat.size()) return std::nullopt;
  const size_t end = std::min(proc_stat.find('\n', pos), proc_stat.size());
  std::string_view line = proc_stat.substr(pos + prefix.size(), end - pos - prefix.size());
  long long value = 0;
  for (int field = 1; field <= 8; ++field) {
    const size_t start = line.find_first_not_of(' ');
    if (start == std::string_view::npos) return std::nullopt;
    line.remove_prefix(start);
    const auto [next, error] = std::from_chars(line.data(), line.data() + line.size(), value);
    if (error != std::errc() || value < 0) return std::nullopt;
    if (next != line.data() + line.size() && *next != ' ') return std::nullopt;
    line.remove_prefix(static_cast<size_t>(next - line.data()));
  }
  return value;
}

std::optional<double> host_steal_seconds() {
  std::ifstream file("/proc/stat");
  if (!file) return std::nullopt;
  std::ostringstream text;
  text << file.rdbuf();
  const std::optional<long long> ticks = parse_proc_stat_steal_ticks(text.str());
  const long hz = sysconf(_SC_CLK_TCK);
  if (!ticks || hz <= 0) return std::nullopt;
  return static_cast<double>(*ticks) / static_cast<double>(hz);
}

}  // namespace pliant
