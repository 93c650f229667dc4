// Time base of the whole pipeline: signed nanoseconds since an arbitrary epoch (the capture's).
#pragma once

#include <cstdint>

namespace drivetap {

using TimeNs = std::int64_t;

inline constexpr TimeNs kNsPerUs = 1'000;
inline constexpr TimeNs kNsPerMs = 1'000'000;
inline constexpr TimeNs kNsPerSecond = 1'000'000'000;

}  // namespace drivetap
