// Pairing stage: Messages -> Transactions on a half-duplex link (docs/protocols.md §1, §2, §7).
//
// Contract: messages of one link arrive in bus order. A request waits for a response with the
// same address and function (exception bit ignored). It ends as `timeout` when the timeout passes,
// or when the master sends another request first (a single-master bus has one request in
// flight). Address 0 is a broadcast: no reply expected. A response with no request waiting is
// `unsolicited`. A reply with a bad checksum pairs as usual but is `bad_reply`. Latency = end of
// request's last character -> start of the response.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "core/message.hpp"
#include "core/transaction.hpp"

namespace drivetap {

struct PairerOptions {
  TimeNs timeout = 1 * kNsPerSecond;
  TimeNs character_time = 0;     // to compute where a request ends
  std::size_t max_pending = 64;  // bound on requests in flight per link (hostile input)
  // False when the times are synthetic (`drivetap decode` lays pasted frames out 20 ms apart): no
  // request ever times out, and one left without a reply is dropped, not reported `timeout`,
  // since nothing tells how long the bus really waited.
  bool clocked = true;
};

// What pairing reads of a decoded telegram: its head (which the drive level reads too) and its
// function. A Message holds it all (pairing_input()); a telegram dissected to its head only
// (DissectDepth::head) has it from its TelegramFindings. Pairing reads the head's checksum verdict
// (a reply with a bad one is `bad_reply`), not its latency.
struct PairingInput : TelegramHead, TelegramFunction {
  bool silences_trusted = true;  // false: the latency is not measured (Message::silences_trusted)
};
PairingInput pairing_input(const Message& m);

// What pairing found for a response: the request it answers and the latency (-1 when hidden).
struct PairingResult {
  bool paired = false;
  std::uint64_t request_number = 0;
  TimeNs latency = -1;
};

class Pairer {
 public:
  explicit Pairer(PairerOptions options) : options_(options) {
    if (!options_.clocked) options_.timeout = std::numeric_limits<TimeNs>::max();
  }

  // Is a request from `address`/`function` on `link` still waiting for its reply at time `at`?
  [[nodiscard]] bool awaiting_reply(std::size_t link, int address, int function, TimeNs at) const;
  // The bytes of the request a reply from `address`/`function` would answer; empty when none.
  // They stay as they are until the next request is added: the reply's add() (which drops its
  // request) leaves them in place, so the caller can still hand them on after pairing.
  [[nodiscard]] std::span<const std::uint8_t> awaited_request(std::size_t link, int address,
                                                              int function, TimeNs at) const;
  // Closes requests whose timeout ran out before `now`. (Inline: called twice a frame, and most
  // calls find nothing to close.)
  void expire(TimeNs now, std::vector<Transaction>& out) {
    if (live_ != 0 && now - slots_[0].end > options_.timeout) expire_some(now, out);
  }
  // Pairs a decoded message. On a paired response sets message.latency and request_number.
  void add(std::size_t link, Message& message, std::vector<Transaction>& out);
  // The same for a telegram given by what pairing reads of it; what it found for a response.
  PairingResult add(std::size_t link, const PairingInput& in, std::vector<Transaction>& out);
  // End of input: every open request is unanswered.
  void finish(std::vector<Transaction>& out);

 private:
  struct Pending {
    std::size_t link;
    int address;
    int function;
    std::uint64_t number;
    ChannelId channel;
    TimeNs start;
    TimeNs end;
    Protocol protocol;
    std::vector<std::uint8_t> bytes;  // the request itself: replies are read in its light
  };
  // The request from `address`/`function` on `link` still waiting at `at`; null when none.
  [[nodiscard]] const Pending* awaited(std::size_t link, int address, int function,
                                       TimeNs at) const;
  void close_unanswered(const Pending& p, std::string detail, std::vector<Transaction>& out,
                        Outcome outcome = Outcome::timeout);
  void expire_some(TimeNs now, std::vector<Transaction>& out);  // expire(), the first is due
  // Drops the requests `drop` picks, keeping the order of the rest. A dropped request's slot (and
  // its bytes' storage) waits past the live ones for the next request: pairing allocates nothing
  // per request.
  template <class Drop>
  void remove_pending(Drop&& drop);

  PairerOptions options_;
  std::vector<Pending> slots_;  // requests in flight, oldest first: slots_[0, live_)
  std::size_t live_ = 0;
};

}  // namespace drivetap
