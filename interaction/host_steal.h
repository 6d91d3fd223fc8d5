// Host steal time: CPU time a hypervisor gave to other guests while this machine's virtual CPUs
// wanted to run (the "steal" column of Linux's /proc/stat). A virtual CPU that is descheduled for a
// millisecond or more makes a 1 kHz haptic tick late whatever the code does, so the haptic
// benchmark reports the steal over its run beside its deadline misses (docs/interaction.md).
#pragma once

#include <optional>
#include <string_view>

namespace pliant {

/// The steal ticks (USER_HZ units) of the aggregate "cpu " line of a /proc/stat text; nullopt if the
/// line is missing, malformed or has fewer than eight values (kernels before 2.6.11 have no steal).
std::optional<long long> parse_proc_stat_steal_ticks(std::string_view proc_stat);

/// Steal time of all CPUs since boot (s), read from /proc/stat; nullopt where it cannot be read.
std::optional<double> host_steal_seconds();

}  // namespace pliant
