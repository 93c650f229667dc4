// Drive binding by evidence (`--drive auto`, the default; docs/reference.md "Drive binding"):
// which family profile a station's traffic fits. Contract:
// - It learns only from paired transactions: a good reply (checksum and plausibility,
//   good_telegram()) read with the good request it answers. A request alone, a reply alone and a
//   broadcast prove nothing.
// - Each transaction is judged for every candidate family that speaks its protocol at its
//   address: it contradicts the family (addresses it does not have, a function or request size it
//   refuses, a value outside the manual's table, a bit the manual does not describe, an exception
//   code it does not list; but a request the drive refuses with an exception contradicts
//   nothing by its addresses, function or size), or it fits it with a value the family constrains
//   (its own protocol, a listed vendor exception code, a nonzero value the manual's table lists, a
//   nonzero status word that sets only bits the manual describes), or it proves nothing (addresses
//   and values any device could have: plain requests to common addresses, zeros, registers of any
//   value, a control word, which the master writes).
// - A station is bound to the family that alone explains at least kBindTransactions transactions
//   ("medium"), and "high" from kHighTransactions; never on one. A family contradicted by more
//   than one transaction in four of those it fits is never bound, and a bound one that falls to
//   that is let go; another family rebinds the station only when it explains more transactions
//   alone by kBindTransactions.
// - Until then the station is generic (no drive-level meaning). Each binding change is a
//   `drive_bound` BusEvent whose evidence names what fitted and what did not.
// - A decided station is no longer weighed: bound, with kDecidedTransactions it alone explains
//   and none contradicting; or generic, every family contradicted kDecidedContradictions times
//   and explaining none alone. Its protocol changing weighs it again.
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

// What a transaction showed of a family: each reason a bit (DriveBinder::reason_text()).
enum class BindingReason : std::uint8_t {
  // fitting, and telling
  own_protocol,
  vendor_exception,
  table_value,
  described_bits,
  // fitting, proving nothing by itself
  named_addresses,
  // contradicting
  unknown_addresses,
  refused_function,
  refused_size,
  value_outside_table,
  undescribed_bits,
  unlisted_exception,
};
inline constexpr std::uint16_t reason_bit(BindingReason r) {
  return static_cast<std::uint16_t>(1u << static_cast<unsigned>(r));
}
inline constexpr std::uint16_t kTellingReasons =
    reason_bit(BindingReason::own_protocol) | reason_bit(BindingReason::vendor_exception) |
    reason_bit(BindingReason::table_value) | reason_bit(BindingReason::described_bits);
inline constexpr std::uint16_t kContradictingReasons =
    reason_bit(BindingReason::unknown_addresses) | reason_bit(BindingReason::refused_function) |
    reason_bit(BindingReason::refused_size) | reason_bit(BindingReason::value_outside_table) |
    reason_bit(BindingReason::undescribed_bits) | reason_bit(BindingReason::unlisted_exception);

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
  // in the one lookup of the station the pipeline makes for every frame. A reply weighs only when
  // `telegram` was read with its request (TelegramDriveRecords::answers_request()).
  // `telegram`'s records are read only if the binder weighs it, and are then there for the
  // annotation of the same telegram.
  const DriveProfile* learn_bound(std::size_t link, TelegramDriveRecords& telegram,
                                  std::optional<BusEvent>& changed);
  // The same with a reading of its own; a reply with the request it answers.
  const DriveProfile* learn_bound(std::size_t link, const TelegramHead& telegram,
                                  std::optional<BusEvent>& changed,
                                  std::span<const std::uint8_t> request = {}) {
    TelegramDriveRecords records(records_, telegram, request);
    return learn_bound(link, records, changed);
  }

  // One family's count of a station's transactions.
  struct Tally {
    std::uint32_t fits = 0;         // transactions with a value the family constrains, fitting
    std::uint32_t alone = 0;        // of those, the ones no other candidate fits
    std::uint32_t contradicts = 0;  // transactions that contradict it
    std::uint16_t fitted = 0;       // the reasons seen fitting (reason_bit())
    std::uint16_t denied = 0;       // the reasons seen contradicting
  };
  // One family's judgement of the station's request awaiting its reply.
  struct Judgement {
    std::uint16_t fitted = 0, denied = 0;
  };
  struct Station {
    std::vector<Tally> tally;  // per candidate
    // Per candidate: protocol or address range rule it out (bytes, not std::vector<bool>'s
    // bits: read for every candidate of every frame).
    std::vector<std::uint8_t> excluded;
    // The last good request, judged for each candidate, until its reply comes (a request that
    // is not good, or a second request, puts it aside).
    std::vector<Judgement> awaiting;
    bool has_awaiting = false;
    int bound = -1;  // candidate index, -1 = generic
    // Of the current binding: "high", "medium" (static text: set on every transaction).
    std::string_view confidence;
    std::uint64_t frames = 0;
    std::uint64_t transactions = 0;  // paired and weighed
    // Frames weighed until the verdict was decided (0: not decided), after which the station's
    // telegrams are no longer weighed (its protocol changing weighs them again).
    std::uint64_t decided_after = 0;
    // The protocol of its last telegram and its protocol_bit(), worked out again only when the
    // protocol changes (a registry lookup for every frame cost the hot path).
    Protocol protocol = Protocol::unknown;
    std::uint32_t protocol_bit = 0;
  };
  using Key = std::pair<std::size_t, int>;  // link, station address
  [[nodiscard]] const DriveProfile* bound(std::size_t link, int address) const;
  // The station is bound with confidence "high": what depends on its family (timing rules) is
  // no longer held back (Pipeline::hold_family_findings()).
  [[nodiscard]] bool sure(std::size_t link, int address) const;
  [[nodiscard]] const std::map<Key, Station>& stations() const { return stations_; }
  [[nodiscard]] const DriveProfile& candidate(int index) const { return *candidates_[index]; }
  [[nodiscard]] std::size_t candidate_count() const { return candidates_.size(); }
  // Distinct requests whose addressing is remembered (for every candidate); past it the memo
  // starts again: a bound on memory for a bus that never repeats a request.
  static constexpr std::size_t kMaxRememberedRequests = 1024;
  // Transactions a family must explain alone: to be bound (confidence "medium"), for "high".
  static constexpr std::uint32_t kBindTransactions = 2, kHighTransactions = 8;
  // Decided (no longer weighed): bound, with this many explained alone and none contradicting.
  static constexpr std::uint32_t kDecidedTransactions = 256;
  // Decided generic: every family contradicted this often, and none explaining one alone.
  static constexpr std::uint32_t kDecidedContradictions = 64;
  // "auto, confidence high: 12 of 12 transactions only ERMAN E-9P/9G explains (...)".
  [[nodiscard]] std::string evidence(const Station& station) const;
  // "a value the manual's table lists", for BindingReason `r`.
  static std::string_view reason_text(BindingReason r);

  // A register whose values a profile constrains: an enum (the manual's table of values) or a
  // word of described bits (a status or control word). Sorted by key().
  struct CheckedRegister {
    RegisterKind kind;
    std::uint32_t address;
    const std::map<std::uint32_t, std::string>* table = nullptr;
    std::uint32_t bit_mask = 0;   // the bits the manual describes (texts and drive-state bits)
    std::uint32_t flag_bits = 0;  // of a register with a table too: bits beside the table's value
    bool status = false;          // the drive's status word (role status): its bits can fit
    [[nodiscard]] std::uint64_t key() const {
      return std::uint64_t{static_cast<std::uint8_t>(kind)} << 32 | address;
    }
  };

 private:
  // The candidate that explains most transactions alone (-1: none not excluded), and the
  // runner-up.
  std::pair<int, int> best_of(const Station& station) const;
  [[nodiscard]] bool qualifies(const Tally& t) const;
  // What the request `records` shows of each candidate's addressing, in candidate order: the
  // same poll repeats all day, and it depends only on the candidate and `key` (the function,
  // space, start and count), so it is worked out once a request for all candidates.
  std::span<const Judgement> request_judgements(std::uint64_t key, const DriveRecords& records);
  static std::uint32_t protocol_bit(Protocol protocol) {
    return std::uint32_t{1} << protocol_index(protocol);
  }

  std::vector<const DriveProfile*> candidates_;
  std::vector<std::uint32_t> protocols_;    // per candidate: protocol_bit() of each it speaks
  std::vector<AddressEvidence> addresses_;  // per candidate
  std::vector<std::vector<CheckedRegister>> checked_;  // per candidate
  std::map<Key, Station> stations_;
  // The station of (link, address) for addresses below kIndexedAddresses (every bus address of the
  // four protocols), by link * kIndexedAddresses + address: one lookup a frame that does not walk
  // the map (map nodes stay where they are).
  static constexpr int kIndexedAddresses = 256;
  std::vector<Station*> station_index_;
  Station& station_of(std::size_t link, int address);
  DriveRecordReader records_;  // the telegram's, when the caller lends no reading
  // Request key -> offset in judgement_pool_ of its candidates' judgements
  // (kMaxRememberedRequests at most).
  std::unordered_map<std::uint64_t, std::size_t> request_judgements_;
  std::vector<Judgement> judgement_pool_;
  std::vector<Judgement> scratch_;  // a transaction's judgements
};

}  // namespace drivetap
