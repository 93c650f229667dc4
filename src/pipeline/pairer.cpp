// Request/response pairing on a half-duplex link (docs/protocols.md §1-§2, §7 on FC 05/06/08
// echoes).
#include "pipeline/pairer.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>
#include <iterator>

#include "core/enum_text.hpp"

namespace drivetap {

std::string_view outcome_id(Outcome o) {
  static constexpr std::string_view kOutcomeIds[] = {
      "ok", "exception", "timeout", "broadcast", "unsolicited", "bad_reply", "pending"};
  static_assert(std::size(kOutcomeIds) == static_cast<std::size_t>(Outcome::pending) + 1);
  return enum_text(o, kOutcomeIds, std::string_view{"ok"});
}

namespace {
// The function a reply answers: Modbus marks exceptions with bit 7; -1 = protocol without one.
int function_key(int function) {
  return function < 0 ? -1 : (function & 0x7F);
}
}  // namespace

const Pairer::Pending* Pairer::awaited(std::size_t link, int address, int function,
                                       TimeNs at) const {
  for (std::size_t i = 0; i < live_; ++i) {
    const Pending& p = slots_[i];
    if (p.link == link && p.address == address && p.function == function_key(function) &&
        at - p.end <= options_.timeout)
      return &p;
  }
  return nullptr;
}

bool Pairer::awaiting_reply(std::size_t link, int address, int function, TimeNs at) const {
  return awaited(link, address, function, at) != nullptr;
}

std::span<const std::uint8_t> Pairer::awaited_request(std::size_t link, int address, int function,
                                                      TimeNs at) const {
  const Pending* p = awaited(link, address, function, at);
  return p ? std::span<const std::uint8_t>(p->bytes) : std::span<const std::uint8_t>();
}

template <class Drop>
void Pairer::remove_pending(Drop&& drop) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < live_; ++i) {
    if (drop(i, slots_[i])) continue;
    if (kept != i) std::swap(slots_[kept], slots_[i]);
    ++kept;
  }
  live_ = kept;
}

void Pairer::close_unanswered(const Pending& p, std::string detail, std::vector<Transaction>& out,
                              Outcome outcome) {
  if (!options_.clocked) return;  // (no clock: not known to be unanswered, see PairerOptions)
  Transaction t;
  t.outcome = outcome;
  t.protocol = p.protocol;
  t.channel = p.channel;
  t.address = p.address;
  t.function = p.function;
  t.request_number = p.number;
  t.request_time = p.start;
  t.detail = std::move(detail);
  out.push_back(std::move(t));
}

void Pairer::expire_some(TimeNs now, std::vector<Transaction>& out) {
  // Requests are in request order: the expired ones are a prefix.
  std::size_t expired = 0;
  while (expired < live_ && now - slots_[expired].end > options_.timeout) {
    close_unanswered(slots_[expired],
                     fmt::format(FMT_COMPILE("no reply within {} ms"), options_.timeout / kNsPerMs),
                     out);
    ++expired;
  }
  if (expired > 0) remove_pending([&](std::size_t i, const Pending&) { return i < expired; });
}

PairingInput pairing_input(const Message& m) {
  PairingInput in;
  static_cast<TelegramHead&>(in) = head_of(m);
  in.function = m.function;
  in.is_exception = m.is_exception;
  in.exception_code = m.exception_code;
  in.silences_trusted = m.silences_trusted;
  return in;
}

void Pairer::add(std::size_t link, Message& m, std::vector<Transaction>& out) {
  const PairingResult r = add(link, pairing_input(m), out);
  if (r.paired) {
    m.latency = r.latency;
    m.request_number = r.request_number;
  }
}

PairingResult Pairer::add(std::size_t link, const PairingInput& m, std::vector<Transaction>& out) {
  const TimeNs start = m.start;
  expire(start, out);
  if (m.direction == Direction::request) {
    // A new request on a single-master link ends every request still open there.
    remove_pending([&](std::size_t, const Pending& p) {
      if (p.link != link) return false;
      close_unanswered(p, "no reply before the next request", out);
      return true;
    });
    if (m.address == 0) {
      Transaction t;
      t.outcome = Outcome::broadcast;
      t.protocol = m.protocol;
      t.channel = m.channel;
      t.address = 0;
      t.function = m.function;
      t.request_number = m.number;
      t.request_time = start;
      out.push_back(std::move(t));
      return {};
    }
    if (live_ >= options_.max_pending) {
      close_unanswered(slots_[0], "dropped: too many requests in flight", out);
      remove_pending([](std::size_t i, const Pending&) { return i == 0; });
    }
    if (live_ == slots_.size()) slots_.emplace_back();
    Pending& p = slots_[live_++];
    p.link = link;
    p.address = m.address;
    p.function = function_key(m.function);
    p.number = m.number;
    p.channel = m.channel;
    p.start = start;
    p.end = m.last_byte + options_.character_time;
    p.protocol = m.protocol;
    p.bytes.assign(m.bytes.begin(), m.bytes.end());
    return {};
  }
  if (m.direction != Direction::response) return {};

  // The reply's transaction, made in place once those it closes before it are out.
  auto transaction = [&]() -> Transaction& {
    Transaction& t = out.emplace_back();
    t.protocol = m.protocol;
    t.address = m.address;
    t.function = function_key(m.function);
    t.response_number = m.number;
    t.response_time = start;
    t.exception_code = m.exception_code;
    return t;
  };
  std::size_t match = live_;
  for (std::size_t i = 0; i < live_; ++i) {
    const Pending& p = slots_[i];
    if (p.link == link && p.address == m.address && p.function == function_key(m.function)) {
      match = i;
      break;
    }
  }
  if (match < live_) {
    const Pending& request = slots_[match];
    // With no silence visible before the reply (bytes stamped per adapter read), the latency is
    // not measurable: report the pairing without a number rather than a false 0 ms.
    // Times that carry no silence at all (USB bursts) measure none either.
    const TimeNs latency = (!m.silences_trusted || m.gap_before == 0 || start < request.end)
                               ? -1
                               : start - request.end;
    const PairingResult found{true, request.number, latency};
    const ChannelId channel = request.channel;
    const TimeNs request_time = request.start;
    // The answered request leaves, and older requests on the same link were never answered
    // (reported before the pairing, in request order).
    remove_pending([&](std::size_t i, const Pending& p) {
      if (i == match) return true;
      if (i < match && p.link == link) {
        close_unanswered(p, "no reply before a later request was answered", out);
        return true;
      }
      return false;
    });
    Transaction& t = transaction();
    // A reply the master cannot trust (its checksum bad) ends the request but is no answer: not
    // `ok`, and not `exception` either, whatever its corrupted function code says.
    t.outcome = m.verdict == ChecksumVerdict::bad ? Outcome::bad_reply
                : m.is_exception                  ? Outcome::exception
                                                  : Outcome::ok;
    t.channel = channel;
    t.request_number = found.request_number;
    t.request_time = request_time;
    t.latency = latency;
    if (latency < 0)
      t.detail = m.silences_trusted ? "latency hidden: no silence visible before the reply"
                                    : "latency hidden: timing not trusted";
    return found;
  }
  Transaction& t = transaction();
  t.outcome = Outcome::unsolicited;
  t.channel = m.channel;
  t.detail = "no request waiting for this reply";
  return {};
}

void Pairer::finish(std::vector<Transaction>& out) {
  for (std::size_t i = 0; i < live_; ++i)
    close_unanswered(slots_[i], "capture ended before a reply", out, Outcome::pending);
  live_ = 0;
}

}  // namespace drivetap
