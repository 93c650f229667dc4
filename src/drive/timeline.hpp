// Drive-state timeline: each drive's last known state (run/stop, direction, setpoint, output
// frequency, current, fault) from the observations of its frames, and the events when it changes
// ("drive 2 (ERMAN E-9P/9G): fault 4 (overcurrent) appeared"). Contract: events come out in frame
// order, at most one per kind and value change; telemetry (output frequency, current, voltage)
// is kept, not announced: it changes with every poll. The states keep their quantities as read
// (Quantity points into its profile): the profiles must outlive the timeline.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/bus_event.hpp"
#include "core/message.hpp"
#include "drive/annotate.hpp"
#include "drive/profile.hpp"

namespace drivetap {

struct DriveState {
  std::string profile_id, profile_name;
  std::optional<bool> running, reverse, fault_active, warning;
  std::optional<Quantity> setpoint, output_frequency, current, voltage;
  std::optional<std::uint32_t> fault_code;
  Quantity fault;  // with fault_code: "4 (overcurrent)"
  std::optional<bool> run_command, reverse_command;
  bool reset_level = false;  // the last command carried the reset bit (edges make events)
  std::uint64_t events = 0;

  // "running, forward, setpoint 50.00 Hz, output frequency 49.87 Hz, current 12.3 A, no fault".
  [[nodiscard]] std::string summary() const;
};

class DriveTimeline {
 public:
  // Folds the observation of `message` (already read with `profile`) into the state of drive
  // (link, message.address) and returns the events it caused.
  // `described` false: the state and its count of changes kept, no event made (no sink shows
  // them: `read --stats`).
  std::vector<BusEvent> observe(std::size_t link, const TelegramHead& telegram,
                                const DriveProfile& profile, const DriveObservation& observed,
                                bool described = true);
  std::vector<BusEvent> observe(std::size_t link, const Message& message,
                                const DriveProfile& profile, const DriveObservation& observed) {
    return observe(link, head_of(message), profile, observed);
  }

  using Key = std::pair<std::size_t, int>;  // link, station address
  [[nodiscard]] const std::map<Key, DriveState>& drives() const { return drives_; }

 private:
  std::map<Key, DriveState> drives_;
};

}  // namespace drivetap
