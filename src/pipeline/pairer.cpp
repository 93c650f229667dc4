// Request/response pairing on a half-duplex link (PROTOCOLS.md §1-§2, §7 on FC 05/06/08 echoes).
#include "pipeline/pairer.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

namespace drivetap {

const char* outcome_id(Outcome o) {
  switch (o) {
    case Outcome::ok:
      return "ok";
    case Outcome::exception:
      return "exception";
    case Outcome::timeout:
      return "timeout";
    case Outcome::broadcast:
      return "broadcast";
    case Outcome::unsolicited:
      return "unsolicited";
  }
  return "ok";
}

namespace {
// The function a reply answers: Modbus marks exceptions with bit 7; -1 = protocol without one.
int function_key(int function) {
  return function < 0 ? -1 : (function & 0x7F);
}
}  // namespace

bool Pairer::awaiting_reply(std::size_t link, int address, int function, TimeNs at) const {
  for (const Pending& p : pending_)
    if (p.link == link && p.address == address && p.function == function_key(function) &&
        at - p.end <= options_.timeout)
      return true;
  return false;
}

std::span<const std::uint8_t> Pairer::awaited_request(std::size_t link, int address, int function,
                                                      TimeNs at) const {
  for (const Pending& p : pending_)
    if (p.link == link && p.address == address && p.function == function_key(function) &&
        at - p.end <= options_.timeout)
      return p.bytes;
  return {};
}

void Pairer::close_unanswered(const Pending& p, std::string detail, std::vector<Transaction>& out) {
  Transaction t;
  t.outcome = Outcome::timeout;
  t.protocol = p.protocol;
  t.channel = p.channel;
  t.address = p.address;
  t.function = p.function;
  t.request_number = p.number;
  t.request_time = p.start;
  t.detail = std::move(detail);
  out.push_back(std::move(t));
}

void Pairer::expire(TimeNs now, std::vector<Transaction>& out) {
  // pending_ is in request order; each pass removes the front or stops.
  while (!pending_.empty() && now - pending_.front().end > options_.timeout) {
    close_unanswered(pending_.front(),
                     fmt::format(FMT_COMPILE("no reply within {} ms"), options_.timeout / kNsPerMs),
                     out);
    pending_.pop_front();
  }
}

void Pairer::add(std::size_t link, Message& m, std::vector<Transaction>& out) {
  const TimeNs start = m.frame.start();
  expire(start, out);
  if (m.direction == Direction::request) {
    // A new request on a single-master link ends every request still open there.
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->link == link) {
        close_unanswered(*it, "no reply before the next request", out);
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
    if (m.address == 0) {
      Transaction t;
      t.outcome = Outcome::broadcast;
      t.protocol = m.protocol;
      t.channel = m.frame.channel;
      t.address = 0;
      t.function = m.function;
      t.request_number = m.frame.number;
      t.request_time = start;
      out.push_back(std::move(t));
      return;
    }
    if (pending_.size() >= options_.max_pending) {
      close_unanswered(pending_.front(), "dropped: too many requests in flight", out);
      pending_.pop_front();
    }
    const TimeNs end = m.frame.events.back().time + options_.character_time;
    pending_.push_back({link, m.address, function_key(m.function), m.frame.number, m.frame.channel,
                        start, end, m.protocol, m.bytes});
    return;
  }
  if (m.direction != Direction::response) return;

  Transaction t;
  t.protocol = m.protocol;
  t.address = m.address;
  t.function = function_key(m.function);
  t.response_number = m.frame.number;
  t.response_time = start;
  t.exception_code = m.exception_code;
  std::size_t match = pending_.size();
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    const Pending& p = pending_[i];
    if (p.link == link && p.address == m.address && p.function == function_key(m.function)) {
      match = i;
      break;
    }
  }
  if (match < pending_.size()) {
    const Pending request = std::move(pending_[match]);
    // Compacted in place, in order: the answered request leaves, and older requests on the same
    // link were never answered.
    std::size_t kept = 0;
    for (std::size_t i = 0; i < pending_.size(); ++i) {
      if (i == match) continue;
      if (i < match && pending_[i].link == link) {
        close_unanswered(pending_[i], "no reply before a later request was answered", out);
        continue;
      }
      if (kept != i) pending_[kept] = std::move(pending_[i]);
      ++kept;
    }
    pending_.resize(kept);
    t.outcome = m.is_exception ? Outcome::exception : Outcome::ok;
    t.channel = request.channel;
    t.request_number = request.number;
    t.request_time = request.start;
    // With no silence visible before the reply (bytes stamped per adapter read), the latency is
    // not measurable: report the pairing without a number rather than a false 0 ms.
    t.latency = (m.frame.gap_before == 0 || start < request.end) ? -1 : start - request.end;
    if (t.latency < 0) t.detail = "latency hidden: no silence visible before the reply";
    m.latency = t.latency;
    m.request_number = request.number;
    out.push_back(std::move(t));
    return;
  }
  t.outcome = Outcome::unsolicited;
  t.channel = m.frame.channel;
  t.detail = "no request waiting for this reply";
  out.push_back(std::move(t));
}

void Pairer::finish(std::vector<Transaction>& out) {
  for (const Pending& p : pending_) close_unanswered(p, "capture ended before a reply", out);
  pending_.clear();
}

}  // namespace drivetap
