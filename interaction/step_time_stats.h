// Step-time statistics for the fixed-rate loop: p50, p99 and max of measured tick times.
#pragma once

#include <cstddef>
#include <vector>

namespace pliant {

/// p50, p99 and max of a set of durations (s).
struct Percentiles {
  double p50 = 0.0;
  double p99 = 0.0;
  double max = 0.0;
  long count = 0;
};

/// Collects durations and reports percentiles (nearest-rank on the sorted samples).
class StepTimeStats {
 public:
  void add(double seconds);
  void clear() { samples_.clear(); }
  /// Preallocates room for n samples (so add() does not allocate until then).
  void reserve(size_t n) { samples_.reserve(n); }
  long count() const { return static_cast<long>(samples_.size()); }
  /// Nearest-rank percentile: the smallest sample with at least q of the samples <= it; q in (0, 1].
  double percentile(double q) const;
  Percentiles summary() const;
  const std::vector<double>& samples() const { return samples_; }

 private:
  std::vector<double> samples_;
};

}  // namespace pliant
