// Drive binding by guess (`--drive auto`, the default): which family profile a station's traffic
// fits — protocol, station address range, function codes, register and parameter addresses it
// reads and writes, vendor exception codes. Contract: learns only from good telegrams (checksum
// and plausibility, good_telegram()); a station is bound once one profile leads every other by a
// clear margin (never on low confidence), rebound only when another overtakes it by more, and let
// go when its own evidence sinks to -kDecidedLead; a station no profile fits stays on "generic
// Modbus" (no drive-level annotation). A verdict with a lead of kDecidedLead is decided: the
// station's telegrams are no longer weighed. Each binding change is a `drive_bound` BusEvent with
// the evidence.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "core/bus_event.hpp"
#include "core/message.hpp"
#include "drive/address_evidence.hpp"
#include "drive/profile.hpp"
#include "drive/records.hpp"

namespace drivetap {

class DriveBinder {
 public:
  explicit DriveBinder(std::vector<const DriveProfile*> candidates);
  // (A copy's index would point into the original's stations; a move keeps the map's nodes.)
  DriveBinder(const DriveBinder&) = delete;
  DriveBinder& operator=(const DriveBinder&) = delete;
  DriveBinder(DriveBinder&&) = default;
  DriveBinder& operator=(DriveBinder&&) = default;

  // Weighs what `telegram` says about its station; `changed` is set to the event when the
  // station's binding changed. Returns the profile the station is bound to afterwards (bound()),
  // in the one lookup of the station the pipeline makes for every frame.
  // `telegram`'s records are read only if the binder weighs it, and are then there for the
  // annotation of the same telegram.
  const DriveProfile* learn_bound(std::size_t link, TelegramDriveRecords& telegram,
                                  std::optional<BusEvent>& changed);
  // The same with a reading of its own (a reply read without its request).
  const DriveProfile* learn_bound(std::size_t link, const TelegramHead& telegram,
                                  std::optional<BusEvent>& changed) {
    TelegramDriveRecords records(records_, telegram, {});
    return learn_bound(link, records, changed);
  }

  struct Station {
    std::vector<double> score;  // per candidate: fitting minus contradicting observations
    // Per candidate: protocol or address range rule it out (bytes, not std::vector<bool>'s
    // bits: read for every candidate of every frame).
    std::vector<std::uint8_t> excluded;
    int bound = -1;  // candidate index, -1 = generic
    // Of the current binding: "high", "medium", "low" (static text: set on every frame).
    std::string_view confidence;
    std::uint64_t frames = 0;
    // Frames weighed until the verdict was decided (0: not decided): a lead of kDecidedLead,
    // after which the station's telegrams are no longer weighed (its protocol changing weighs
    // them again).
    std::uint64_t decided_after = 0;
    // The protocol of its last telegram and its protocol_bit(), worked out again only when the
    // protocol changes (a registry lookup for every frame cost the hot path).
    Protocol protocol = Protocol::unknown;
    std::uint32_t protocol_bit = 0;
  };
  using Key = std::pair<std::size_t, int>;  // link, station address
  [[nodiscard]] const DriveProfile* bound(std::size_t link, int address) const;
  [[nodiscard]] const std::map<Key, Station>& stations() const { return stations_; }
  [[nodiscard]] const DriveProfile& candidate(int index) const { return *candidates_[index]; }
  // Distinct requests whose evidence is remembered (for every candidate); past it the memo starts
  // again: a bound on memory for a bus that never repeats a request.
  static constexpr std::size_t kMaxRememberedRequests = 1024;
  // The lead that decides a station for good: its bound profile over every other, or (generic)
  // every profile's deficit. A rebinding needs a swing of more than that: a bus's traffic does not
  // turn after hundreds of contradicting addresses, and weighing each request of a station that
  // fits no family, with its random ranges, cost more than decoding it.
  static constexpr double kDecidedLead = 256;
  // "auto, confidence high: evidence +12, next best ERMAN ER-G +3" for a station.
  [[nodiscard]] std::string evidence(const Station& station) const;

 private:
  // Ranks the candidates of a station: best index and the runner-up's score.
  std::pair<int, std::optional<double>> best_of(const Station& station) const;

  // Evidence of the request `records` for each candidate, in candidate order: the same poll
  // repeats all day, and the evidence depends only on the candidate and `key` (the function,
  // space, start and count), so it is worked out once a request for all candidates and looked up
  // once a frame.
  std::span<const double> request_evidence(std::uint64_t key, const DriveRecords& records);
  static std::uint32_t protocol_bit(Protocol protocol) {
    return std::uint32_t{1} << protocol_index(protocol);
  }

  std::vector<const DriveProfile*> candidates_;
  std::vector<std::uint32_t> protocols_;    // per candidate: protocol_bit() of each it speaks
  std::vector<AddressEvidence> addresses_;  // per candidate
  std::map<Key, Station> stations_;
  // The station of (link, address) for addresses below kIndexedAddresses (every bus address of the
  // four protocols), by link * kIndexedAddresses + address: one lookup a frame that does not walk
  // the map (map nodes stay where they are).
  static constexpr int kIndexedAddresses = 256;
  std::vector<Station*> station_index_;
  Station& station_of(std::size_t link, int address);
  DriveRecordReader records_;  // the telegram's, when the caller lends no reading
  // Request key -> offset in evidence_pool_ of its candidates' evidence
  // (kMaxRememberedRequests at most).
  std::unordered_map<std::uint64_t, std::size_t> request_evidence_;
  std::vector<double> evidence_pool_;
};

}  // namespace drivetap
