// Counting for the closing summary.
#include "core/stats.hpp"

#include <algorithm>

namespace drivetap {

namespace {
void widen_window(Stats& s, const Frame& f) {
  if (f.events.empty()) return;
  s.first_time = std::min(s.first_time, f.events.front().time);
  s.last_time = std::max(s.last_time, f.events.back().time);
}
}  // namespace

void Stats::count_frame(const Message& m) {
  bool plausible = true;
  for (const Anomaly& a : m.anomalies)
    if (a.kind == AnomalyKind::implausible) plausible = false;
  if (m.frame.events.empty()) {  // (a frame of no bytes widens no window)
    ++frames;
    ++checksum[static_cast<std::size_t>(m.checksum.verdict)];
    if (m.checksum.verdict == ChecksumVerdict::good && plausible) ++good_telegrams;
    return;
  }
  count_telegram(m.frame.size(), m.checksum.verdict, plausible, m.frame.events.front().time,
                 m.frame.events.back().time);
}

void Stats::count_noise(const Frame& f) {
  ++noise_records;
  noise_bytes += f.size();
  bytes += f.size();
  widen_window(*this, f);
}

void Stats::count_transaction(const Transaction& t) {
  ++transactions;
  ++outcomes[static_cast<std::size_t>(t.outcome)];
  if (t.latency >= 0) {
    ++latency_count;
    latency_sum += t.latency;
    latency_min = std::min(latency_min, t.latency);
    latency_max = std::max(latency_max, t.latency);
  }
}

}  // namespace drivetap
