// Drive-state timeline (src/drive/timeline.hpp): state changes become events.
#include "drive/timeline.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

namespace drivetap {

std::string DriveState::summary() const {
  std::vector<std::string> parts;
  if (running) parts.push_back(*running ? "running" : "stopped");
  if (reverse) parts.push_back(*reverse ? "reverse" : "forward");
  if (setpoint) parts.push_back("setpoint " + setpoint->text());
  if (output_frequency) parts.push_back("output frequency " + output_frequency->text());
  if (current) parts.push_back("current " + current->text());
  if (voltage) parts.push_back("voltage " + voltage->text());
  if (fault_code)
    parts.push_back(*fault_code ? "fault " + fault.text() : "no fault");
  else if (fault_active)
    parts.push_back(*fault_active ? "fault" : "no fault");
  if (warning && *warning) parts.push_back("warning");
  if (parts.empty()) return "state not seen";
  return fmt::format(FMT_COMPILE("{}"), fmt::join(parts, ", "));
}

std::vector<BusEvent> DriveTimeline::observe(std::size_t link, const TelegramHead& m,
                                             const DriveProfile& profile, const DriveObservation& o,
                                             bool described) {
  std::vector<BusEvent> events;
  DriveState& s = drives_[{link, m.address}];
  if (s.profile_id != profile.id) {
    s.profile_id = profile.id;
    s.profile_name = profile.name;
  }
  // A state change: counted, and made an event when `described` (`text()` gives its kind, what
  // it says, and the values from and to, formatted only then).
  struct EventText {
    EventKind kind;
    std::string what, from, to;
    bool status_word = false;  // a fault: the status word's fault bit, not a fault code
  };
  auto emit = [&](auto&& text) {
    ++s.events;
    if (!described) return;
    EventText t = text();
    BusEvent e;
    e.time = m.start;
    e.channel = m.channel;
    e.kind = t.kind;
    e.protocol = m.protocol;
    e.address = m.address;
    e.profile = profile.id;
    e.frame = m.number;
    e.detail = fmt::format(FMT_COMPILE("drive {} ({}): {}"), m.address, profile.name, t.what);
    e.from = std::move(t.from);
    e.to = std::move(t.to);
    e.status_word = t.status_word;
    events.push_back(std::move(e));
  };

  // A two-state value's name; "" while it is unknown.
  auto word = [](const std::optional<bool>& v, const char* on, const char* off) -> std::string {
    return v ? (*v ? on : off) : "";
  };
  // A setpoint that differs from the last one known, whether commanded or read back.
  auto setpoint_change = [&](const Quantity& to, const char* suffix) {
    if (s.setpoint && s.setpoint->same_text(to)) return;
    emit([&] {
      const std::string from = s.setpoint ? s.setpoint->text() : "", text = to.text();
      return EventText{EventKind::setpoint,
                       s.setpoint
                           ? fmt::format(FMT_COMPILE("setpoint {} -> {}{}"), from, text, suffix)
                           : fmt::format(FMT_COMPILE("setpoint {}{}"), text, suffix),
                       from, text};
    });
    s.setpoint = to;
  };

  // What the master commanded.
  if (o.run_command && o.run_command != s.run_command) {
    emit([&] {
      const std::string to = word(o.run_command, "start", "stop");
      return EventText{EventKind::command, to + " commanded", word(s.run_command, "start", "stop"),
                       to};
    });
    s.run_command = o.run_command;
  }
  if (o.reverse_command && o.reverse_command != s.reverse_command) {
    // Forward is every drive's default: the first command says something only when it reverses.
    if (s.reverse_command || *o.reverse_command) {
      emit([&] {
        const std::string to = word(o.reverse_command, "reverse", "forward");
        return EventText{EventKind::command, to + " commanded",
                         word(s.reverse_command, "reverse", "forward"), to};
      });
    }
    s.reverse_command = o.reverse_command;
  }
  const bool is_command = o.run_command || o.reverse_command || o.setpoint_command;
  if (o.reset_command && !s.reset_level)
    emit([] { return EventText{EventKind::command, "fault reset commanded", "", "reset"}; });
  if (o.reset_command || is_command) s.reset_level = o.reset_command;
  if (o.setpoint_command) setpoint_change(*o.setpoint_command, " commanded");

  // What the drive reported.
  if (o.running && o.running != s.running) {
    emit([&] {
      const std::string to = word(o.running, "running", "stopped");
      return EventText{EventKind::running, to, word(s.running, "running", "stopped"), to};
    });
    s.running = o.running;
  }
  if (o.reverse && o.reverse != s.reverse) {
    if (s.reverse) {
      emit([&] {
        const std::string from = word(s.reverse, "reverse", "forward");
        const std::string to = word(o.reverse, "reverse", "forward");
        return EventText{EventKind::direction,
                         fmt::format(FMT_COMPILE("direction {} -> {}"), from, to), from, to};
      });
    }
    s.reverse = o.reverse;
  }
  if (o.setpoint) setpoint_change(*o.setpoint, "");
  if (o.fault_code && o.fault_code != s.fault_code) {
    const std::uint32_t was = s.fault_code.value_or(0);
    if (*o.fault_code != 0 && was == 0)
      emit([&] {
        const std::string to = o.fault.text();
        return EventText{EventKind::fault, fmt::format(FMT_COMPILE("fault {} appeared"), to), "",
                         to};
      });
    else if (*o.fault_code == 0 && was != 0)
      emit([&] {
        const std::string from = s.fault.text();
        return EventText{EventKind::fault, fmt::format(FMT_COMPILE("fault {} cleared"), from), from,
                         ""};
      });
    else if (*o.fault_code != 0)
      emit([&] {
        const std::string from = s.fault.text(), to = o.fault.text();
        return EventText{EventKind::fault, fmt::format(FMT_COMPILE("fault {} -> {}"), from, to),
                         from, to};
      });
    s.fault_code = o.fault_code;
    s.fault = o.fault;
  }
  if (o.fault_active && o.fault_active != s.fault_active) {
    if (*o.fault_active || s.fault_active)
      emit([&] {
        return EventText{
            EventKind::fault,
            *o.fault_active ? "status word shows a fault" : "status word fault cleared",
            *o.fault_active ? "" : "fault", *o.fault_active ? "fault" : "", true};
      });
    s.fault_active = o.fault_active;
  }
  if (o.warning && o.warning != s.warning) {
    if (*o.warning || s.warning)
      emit([&] {
        return EventText{EventKind::warning, *o.warning ? "warning on" : "warning off",
                         *o.warning ? "" : "warning", *o.warning ? "warning" : ""};
      });
    s.warning = o.warning;
  }
  if (o.output_frequency) s.output_frequency = o.output_frequency;
  if (o.current) s.current = o.current;
  if (o.voltage) s.voltage = o.voltage;
  return events;
}

}  // namespace drivetap
