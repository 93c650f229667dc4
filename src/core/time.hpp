// Time base of the whole pipeline: signed nanoseconds since an arbitrary epoch (the capture's).
#pragma once

#include <cstdint>

namespace drivetap {

using TimeNs = std::int64_t;

inline constexpr TimeNs kNsPerUs = 1'000;
inline constexpr TimeNs kNsPerMs = 1'000'000;
inline constexpr TimeNs kNsPerSecond = 1'000'000'000;

// Every source keeps times inside (-2^62, 2^62) ns (about +-146 years around the capture epoch)
// and intervals (t1.5, t3.5, timeouts) at or below one hour, so that the sums the pipeline forms
// (time + interval + margin) never overflow. Input outside these bounds is a read error.
inline constexpr TimeNs kTimeLimit = TimeNs{1} << 62;
inline constexpr TimeNs kMaxInterval = 3600 * kNsPerSecond;

inline constexpr bool time_in_range(TimeNs t) {
  return t > -kTimeLimit && t < kTimeLimit;
}

}  // namespace drivetap
