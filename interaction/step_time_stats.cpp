#include "interaction/step_time_stats.h"

#include <algorithm>
#include <cmath>

namespace pliant {

void StepTimeStats::add(double seconds) { samples_.push_back(seconds); }

double StepTimeStats::percentile(double q) const {
  if (samples_.empty()) return 0.0;
  std::vector<double> sorted = samples_;
  // Nearest rank: the ceil(q n)-th smallest sample (1-based).
  const auto n = static_cast<double>(sorted.size());
  const auto rank = static_cast<size_t>(std::clamp(std::ceil(q * n), 1.0, n)) - 1;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(rank), sorted.end());
  return sorted[rank];
}

Percentiles StepTimeStats::summary() const {
  Percentiles p;
  p.count = count();
  if (samples_.empty()) return p;
  p.p50 = percentile(0.5);
  p.p99 = percentile(0.99);
  p.max = *std::max_element(samples_.begin(), samples_.end());
  return p;
}

}  // namespace pliant
