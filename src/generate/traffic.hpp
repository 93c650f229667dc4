// Capture generator: large, realistic, reproducible bus traffic for benchmarks and tests.
//
// Four links, each its own channel (and so its own link, core/byte_event.hpp), polled at the
// same time in simulated time:
//   rtu    Modbus RTU: a master polling an ERMAN E-9 (1), an E5-8200 (2), an ER-G (3) and a
//          Danfoss VLT AQUA over Modbus (4) with the registers, coils and function codes their
//          profiles (dissectors/profiles/*.toml) name
//   fc     Danfoss FC protocol: CTW/REF -> STW/MAV telegrams and parameter reads, VLT AQUA 5, 6
//   eds    Easydrive '~' protocol: status queries, running values, run control, EDS1000 7, 8
//   ascii  Modbus ASCII: an E5-8200 (9)
// with injected faults whose every instance drivetap must report: exceptions, timeouts (no
// reply), checksum errors (one byte changed), byte-swapped CRCs, noise between frames, UART
// parity marks, and breaks of the drives' timing rules. Everything else keeps those rules.
//
// Checksums come from the project's own functions (core/checksum.hpp, the FC BCC and Easydrive
// SUM of their dissectors). The random stream is our own (splitmix64 and plain integer
// arithmetic, no std:: distributions), so a seed gives the same bytes on every platform.
// Records come out one at a time in time order: memory stays constant whatever the size.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/checksum.hpp"
#include "core/serial_config.hpp"
#include "core/time.hpp"

namespace drivetap::generate {

enum class Mix : std::uint8_t {
  all,         // the four links, most of the traffic Modbus RTU
  modbus_rtu,  // only the Modbus RTU link (what tshark can decode too)
};
// --mix NAME -> its Mix, nullopt for another name; and what --mix's help says of the mixes.
std::optional<Mix> mix_from_name(std::string_view name);
extern const char* const kMixHelp;
extern const char* const kMixNames;  // "all or modbus-rtu"

struct Options {
  std::uint64_t frames = 100000;  // records to write: requests + replies + noise records
  std::uint64_t seed = 1;
  Mix mix = Mix::all;
};

enum class RecordKind : std::uint8_t { request, reply, noise };

// One frame or noise record: a byte-log line, a packet of the pcapng.
struct Record {
  std::size_t link = 0;  // index into Generator::links()
  RecordKind kind = RecordKind::request;
  TimeNs start = 0;  // start bit of the first byte; the bytes follow back to back
  std::vector<std::uint8_t> bytes;
  std::vector<std::uint8_t> flags;  // UART marks per byte (core/byte_event.hpp UartFlag)
  // What drivetap must report about it.
  bool exception = false;  // a Modbus exception reply
  ChecksumVerdict checksum = ChecksumVerdict::good;
  int parity_errors = 0;
  int timing_breaks = 0;  // drive timing rules this frame breaks
  std::string note;       // what was injected, for the byte log's comment ("" when nothing)
};

// What was written, per link and in total.
struct Counts {
  std::uint64_t frames = 0, requests = 0, replies = 0, exceptions = 0;
  std::uint64_t checksum_bad = 0, checksum_swapped = 0;
  std::uint64_t bad_replies = 0;  // replies with a bad checksum: the `bad_reply` outcome
  std::uint64_t noise_records = 0, noise_bytes = 0, parity_errors = 0, timing_rule = 0;
  std::uint64_t bytes = 0;
  // A request left waiting at the end, whose reply may have been on the way: drivetap's `pending`.
  std::uint64_t pending = 0;
  // Every reply answers one request, and there are no broadcasts: the rest went unanswered.
  [[nodiscard]] std::uint64_t timeouts() const { return requests - replies - pending; }
  void add(const Record& r);
};

struct LinkInfo {
  std::string channel;   // "rtu", "fc", "eds", "ascii"
  std::string protocol;  // JSON protocol id: modbus-rtu, danfoss-fc, easydrive, modbus-ascii
  std::string drives;    // "1=e9 2=e5-8200 ...": the stations and their profiles
};

class Link;

class Generator {
 public:
  explicit Generator(const Options& options);
  ~Generator();
  Generator(const Generator&) = delete;
  Generator& operator=(const Generator&) = delete;

  // The line settings of every link: a capture file holds one setting (docs/reference.md "Generated
  // captures"), 19200 8E1, what the Modbus RTU and FC protocols use.
  static SerialConfig serial();

  // The next record in time order; false once options.frames records were given.
  bool next(Record& out);

  [[nodiscard]] const std::vector<LinkInfo>& links() const { return info_; }
  [[nodiscard]] const std::vector<Counts>& counts() const { return counts_; }
  // All links' counts together.
  [[nodiscard]] const Counts& total() const { return total_; }
  // --drive bindings for every station: "1=e9 2=e5-8200 ...".
  [[nodiscard]] std::string drive_bindings() const;
  // The truth file: what was written, as one JSON object (counts in total and per link).
  [[nodiscard]] std::string truth_json() const;

 private:
  Options options_;
  std::vector<std::unique_ptr<Link>> links_;
  std::vector<LinkInfo> info_;
  std::vector<std::deque<Record>> queues_;
  std::vector<Counts> counts_;
  // Per link: the end of its last record when that is a request (else -1); the last start of all.
  std::vector<TimeNs> open_request_end_;
  TimeNs last_start_ = 0;
  Counts total_;
  std::uint64_t written_ = 0;
};

}  // namespace drivetap::generate
