// ByteSource: what every capture source offers the pipeline — settings found in the capture,
// then a time-ordered stream of ByteEvents (per channel), with its own findings and notes.
#pragma once

#include <csignal>
#include <optional>
#include <string>
#include <vector>

#include "core/anomaly.hpp"
#include "core/byte_event.hpp"
#include "core/byte_events.hpp"
#include "core/message.hpp"
#include "core/serial_config.hpp"

namespace drivetap {

// What a capture says about the run that made it (byte-log header, drivetap pcapng interfaces).
struct RunSettings {
  std::optional<SerialConfig> serial;
  std::optional<TimeNs> t15, t35, reply_timeout, max_hold;
  std::optional<Protocol> protocol;
};

class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Reads what precedes the first byte (headers, interface descriptions). False on error.
  virtual bool read_header() = 0;
  [[nodiscard]] virtual RunSettings settings() const = 0;
  // The character time that spaces bytes whose individual times the capture does not give.
  virtual void set_character_time(TimeNs t) = 0;
  // Next byte; false at the end or on error (then error() is non-empty).
  virtual bool next(ByteEvent& out) = 0;
  // The next bytes into `out` (cleared first), exactly those next() would give one at a time,
  // at most a packet's worth; false at the end or on error. Findings taken after a batch belong
  // before its first byte. The default gives one byte per batch; sources with packets override.
  virtual bool next_batch(std::vector<ByteEvent>& out) {
    out.clear();
    ByteEvent e;
    if (!next(e)) return false;
    out.push_back(e);
    return true;
  }
  // The same bytes as next_batch() as runs (ByteRun: a packet's bytes with their first time and
  // spacing), appended to `out`; false at the end or on error. Sources with packets give a run
  // per packet without making an event per byte; the default groups next_batch()'s events.
  virtual bool append_runs(RunBatch& out) {
    if (!next_batch(run_events_)) return false;
    out.add_events(run_events_);
    return true;
  }
  [[nodiscard]] virtual const std::string& error() const = 0;
  // Findings about the capture itself (e.g. timestamps going backwards), for the pipeline.
  virtual std::vector<Anomaly> take_findings() { return {}; }
  // Lines for stderr at the end (e.g. packets skipped because they carried no serial bytes).
  [[nodiscard]] virtual std::vector<std::string> notes() const { return {}; }
  // A flag a signal handler sets: a source that can work long without handing out a byte (a
  // logic capture's idle line) ends early, as at the end of the capture, once it is set.
  void set_stop_flag(const volatile std::sig_atomic_t* stop) { stop_ = stop; }

 protected:
  [[nodiscard]] bool stop_requested() const { return stop_ && *stop_; }

 private:
  const volatile std::sig_atomic_t* stop_ = nullptr;
  std::vector<ByteEvent> run_events_;  // append_runs()' batch, its storage kept
};

}  // namespace drivetap
