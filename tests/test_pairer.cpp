// Unit tests: request/response pairing on a half-duplex link (docs/protocols.md §1, §2, §7).
#include <gtest/gtest.h>

#include <cstdint>
#include <span>
#include <vector>

#include "core/message.hpp"
#include "core/transaction.hpp"
#include "dissectors/modbus/modbus_protocol.hpp"
#include "pipeline/pairer.hpp"

using namespace drivetap;

namespace {

constexpr TimeNs kChar = 1'146'000;  // about 9600 8E1 (11 bits)
constexpr TimeNs kMs = kNsPerMs;

// A message of `size` bytes starting at `start`, characters back to back.
Message make(Direction dir, int address, int function, TimeNs start, std::size_t size,
             std::uint64_t number, ChannelId channel = 0) {
  Message m;
  m.protocol = protocols::modbus_rtu;
  m.direction = dir;
  m.address = address;
  m.function = function;
  m.is_exception = (function & 0x80) != 0;
  m.frame.channel = channel;
  m.frame.number = number;
  for (std::size_t i = 0; i < size; ++i) {
    ByteEvent e;
    e.time = start + static_cast<TimeNs>(i) * kChar;
    e.byte = static_cast<std::uint8_t>(i == 0 ? address : i == 1 ? function : 0);
    e.channel = channel;
    m.frame.events.push_back(e);
  }
  m.bytes = m.frame.bytes();
  return m;
}

Message request(int address, int function, TimeNs start, std::uint64_t number,
                ChannelId channel = 0) {
  return make(Direction::request, address, function, start, 8, number, channel);
}

Message response(int address, int function, TimeNs start, std::uint64_t number,
                 ChannelId channel = 0) {
  return make(Direction::response, address, function, start, (function & 0x80) ? 5 : 7, number,
              channel);
}

// End of an 8-byte request starting at `start`: last start bit + one character.
constexpr TimeNs request_end(TimeNs start) {
  return start + 7 * kChar + kChar;
}

PairerOptions options(TimeNs timeout = 1000 * kMs, std::size_t max_pending = 64) {
  PairerOptions o;
  o.timeout = timeout;
  o.character_time = kChar;
  o.max_pending = max_pending;
  return o;
}

}  // namespace

TEST(Pairer, OkPairingWithLatency) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(1, 0x03, 10 * kMs, 1);
  p.add(0, q, out);
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(p.awaiting_reply(0, 1, 0x03, 20 * kMs));

  const TimeNs rsp_start = request_end(10 * kMs) + 5 * kMs;
  Message r = response(1, 0x03, rsp_start, 2);
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  const Transaction& t = out[0];
  EXPECT_EQ(t.outcome, Outcome::ok);
  EXPECT_EQ(outcome_id(t.outcome), "ok");
  EXPECT_EQ(t.protocol, protocols::modbus_rtu);
  EXPECT_EQ(t.address, 1);
  EXPECT_EQ(t.function, 0x03);
  EXPECT_EQ(t.request_number, 1u);
  EXPECT_EQ(t.response_number, 2u);
  EXPECT_EQ(t.request_time, 10 * kMs);
  EXPECT_EQ(t.response_time, rsp_start);
  EXPECT_EQ(t.latency, 5 * kMs);
  EXPECT_EQ(t.exception_code, -1);
  // The response message learns its latency and request.
  EXPECT_EQ(r.latency, 5 * kMs);
  EXPECT_EQ(r.request_number, 1u);
  EXPECT_FALSE(p.awaiting_reply(0, 1, 0x03, rsp_start));

  // Nothing is left open.
  std::vector<Transaction> rest;
  p.finish(rest);
  EXPECT_TRUE(rest.empty());
}

TEST(Pairer, LatencyUsesCharacterTime) {
  PairerOptions o = options();
  o.character_time = 0;  // request ends at its last start bit
  Pairer p(o);
  std::vector<Transaction> out;
  Message q = request(1, 0x03, 0, 1);
  p.add(0, q, out);
  Message r = response(1, 0x03, 20 * kMs, 2);
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].latency, 20 * kMs - 7 * kChar);
}

TEST(Pairer, LatencyHiddenWithoutVisibleSilence) {
  // Bytes stamped per adapter read: no silence before the reply, so no latency number.
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(1, 0x03, 0, 1);
  p.add(0, q, out);
  Message r = response(1, 0x03, request_end(0) + 2 * kMs, 2);
  r.frame.gap_before = 0;
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::ok);
  EXPECT_EQ(out[0].request_number, 1u);
  EXPECT_EQ(out[0].latency, -1);
  EXPECT_EQ(r.latency, -1);
  EXPECT_EQ(r.request_number, 1u);
  EXPECT_FALSE(out[0].detail.empty());

  // With visible silence the number is reported.
  Message q2 = request(1, 0x03, 100 * kMs, 3);
  p.add(0, q2, out);
  Message r2 = response(1, 0x03, request_end(100 * kMs) + 2 * kMs, 4);
  r2.frame.gap_before = 2 * kMs;
  p.add(0, r2, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].latency, 2 * kMs);
  EXPECT_TRUE(out[1].detail.empty());
}

TEST(Pairer, ExceptionOutcome) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(2, 0x03, 0, 1);
  p.add(0, q, out);
  Message r = response(2, 0x83, request_end(0) + 3 * kMs, 2);
  r.exception_code = 2;
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::exception);
  EXPECT_EQ(outcome_id(out[0].outcome), "exception");
  EXPECT_EQ(out[0].function, 0x03);  // without the exception bit
  EXPECT_EQ(out[0].exception_code, 2);
  EXPECT_EQ(out[0].request_number, 1u);
  EXPECT_EQ(out[0].latency, 3 * kMs);
  EXPECT_EQ(r.latency, 3 * kMs);
}

TEST(Pairer, TimeoutViaExpire) {
  Pairer p(options(100 * kMs));
  std::vector<Transaction> out;
  Message q = request(5, 0x04, 0, 7, 3);
  p.add(0, q, out);
  const TimeNs end = request_end(0);

  // Exactly at the timeout the request is still waiting.
  EXPECT_TRUE(p.awaiting_reply(0, 5, 0x04, end + 100 * kMs));
  p.expire(end + 100 * kMs, out);
  EXPECT_TRUE(out.empty());

  EXPECT_FALSE(p.awaiting_reply(0, 5, 0x04, end + 100 * kMs + 1));
  p.expire(end + 100 * kMs + 1, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::timeout);
  EXPECT_EQ(outcome_id(out[0].outcome), "timeout");
  EXPECT_EQ(out[0].address, 5);
  EXPECT_EQ(out[0].function, 0x04);
  EXPECT_EQ(out[0].channel, 3);
  EXPECT_EQ(out[0].request_number, 7u);
  EXPECT_EQ(out[0].request_time, 0);
  EXPECT_EQ(out[0].response_number, 0u);
  EXPECT_EQ(out[0].latency, -1);
  EXPECT_EQ(out[0].detail, "no reply within 100 ms");

  // A late reply finds nothing waiting.
  out.clear();
  Message r = response(5, 0x04, end + 200 * kMs, 8);
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::unsolicited);
  EXPECT_EQ(r.latency, -1);
}

TEST(Pairer, LateReplyExpiresTheRequestFirst) {
  Pairer p(options(50 * kMs));
  std::vector<Transaction> out;
  Message q = request(1, 0x03, 0, 1);
  p.add(0, q, out);
  Message r = response(1, 0x03, request_end(0) + 60 * kMs, 2);
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].outcome, Outcome::timeout);
  EXPECT_EQ(out[0].request_number, 1u);
  EXPECT_EQ(out[1].outcome, Outcome::unsolicited);
  EXPECT_EQ(out[1].response_number, 2u);
}

TEST(Pairer, TimeoutWhenMasterSendsAnotherRequest) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q1 = request(1, 0x03, 0, 1);
  p.add(0, q1, out);
  Message q2 = request(2, 0x06, 30 * kMs, 2);
  p.add(0, q2, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::timeout);
  EXPECT_EQ(out[0].request_number, 1u);
  EXPECT_EQ(out[0].address, 1);
  EXPECT_EQ(out[0].detail, "no reply before the next request");
  EXPECT_FALSE(p.awaiting_reply(0, 1, 0x03, 31 * kMs));
  EXPECT_TRUE(p.awaiting_reply(0, 2, 0x06, 31 * kMs));

  // The second request still pairs normally.
  Message r = response(2, 0x06, request_end(30 * kMs) + kMs, 3);
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].outcome, Outcome::ok);
  EXPECT_EQ(out[1].request_number, 2u);
  EXPECT_EQ(out[1].latency, kMs);
}

TEST(Pairer, Broadcast) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(0, 0x10, 5 * kMs, 4, 1);
  p.add(0, q, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::broadcast);
  EXPECT_EQ(outcome_id(out[0].outcome), "broadcast");
  EXPECT_EQ(out[0].address, 0);
  EXPECT_EQ(out[0].function, 0x10);
  EXPECT_EQ(out[0].request_number, 4u);
  EXPECT_EQ(out[0].request_time, 5 * kMs);
  EXPECT_EQ(out[0].channel, 1);
  EXPECT_EQ(out[0].latency, -1);
  EXPECT_FALSE(p.awaiting_reply(0, 0, 0x10, 6 * kMs));

  // Nothing pending: finish() reports nothing.
  std::vector<Transaction> rest;
  p.finish(rest);
  EXPECT_TRUE(rest.empty());
}

TEST(Pairer, BroadcastClosesOpenRequest) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(3, 0x03, 0, 1);
  p.add(0, q, out);
  Message b = request(0, 0x06, 20 * kMs, 2);
  p.add(0, b, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].outcome, Outcome::timeout);
  EXPECT_EQ(out[0].request_number, 1u);
  EXPECT_EQ(out[1].outcome, Outcome::broadcast);
}

TEST(Pairer, UnsolicitedResponse) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message r = response(9, 0x03, 12 * kMs, 3, 2);
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::unsolicited);
  EXPECT_EQ(outcome_id(out[0].outcome), "unsolicited");
  EXPECT_EQ(out[0].address, 9);
  EXPECT_EQ(out[0].function, 0x03);
  EXPECT_EQ(out[0].response_number, 3u);
  EXPECT_EQ(out[0].response_time, 12 * kMs);
  EXPECT_EQ(out[0].request_number, 0u);
  EXPECT_EQ(out[0].channel, 2);
  EXPECT_EQ(out[0].latency, -1);
  EXPECT_EQ(out[0].detail, "no request waiting for this reply");
  EXPECT_EQ(r.latency, -1);
  EXPECT_EQ(r.request_number, 0u);
}

TEST(Pairer, ResponseMustMatchAddressAndFunction) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(1, 0x03, 0, 1);
  p.add(0, q, out);
  Message wrong_addr = response(2, 0x03, 20 * kMs, 2);
  p.add(0, wrong_addr, out);
  Message wrong_fc = response(1, 0x04, 30 * kMs, 3);
  p.add(0, wrong_fc, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].outcome, Outcome::unsolicited);
  EXPECT_EQ(out[1].outcome, Outcome::unsolicited);
  // The request is still waiting and pairs with the right reply.
  EXPECT_TRUE(p.awaiting_reply(0, 1, 0x03, 40 * kMs));
  EXPECT_TRUE(p.awaiting_reply(0, 1, 0x83, 40 * kMs));  // exception bit ignored
  Message right = response(1, 0x03, 40 * kMs, 4);
  p.add(0, right, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[2].outcome, Outcome::ok);
  EXPECT_EQ(out[2].request_number, 1u);
  EXPECT_EQ(out[2].latency, 40 * kMs - request_end(0));
}

TEST(Pairer, AwaitingReply) {
  Pairer p(options(100 * kMs));
  std::vector<Transaction> out;
  Message q = request(4, 0x06, 0, 1);
  p.add(2, q, out);
  const TimeNs end = request_end(0);
  EXPECT_TRUE(p.awaiting_reply(2, 4, 0x06, end));
  EXPECT_TRUE(p.awaiting_reply(2, 4, 0x06, end + 100 * kMs));
  EXPECT_FALSE(p.awaiting_reply(2, 4, 0x06, end + 100 * kMs + 1));
  EXPECT_FALSE(p.awaiting_reply(1, 4, 0x06, end));  // other link
  EXPECT_FALSE(p.awaiting_reply(2, 5, 0x06, end));  // other address
  EXPECT_FALSE(p.awaiting_reply(2, 4, 0x03, end));  // other function
}

// The pipeline hands a reply's request on after pairing the reply: the bytes awaited_request()
// gave stay as they were through that add(), while it expires and drops other requests.
TEST(Pairer, AwaitedRequestOutlivesItsReply) {
  Pairer p(options(50 * kMs));
  std::vector<Transaction> out;
  Message q0 = request(1, 0x03, 0, 1, 0);  // link 0: expired by the time of the reply
  p.add(0, q0, out);
  Message q1 = request(2, 0x04, 10 * kMs, 2, 1);
  p.add(1, q1, out);
  Message q2 = request(3, 0x06, 20 * kMs, 3, 2);
  p.add(2, q2, out);
  const TimeNs at = 60 * kMs;
  const std::span<const std::uint8_t> awaited = p.awaited_request(2, 3, 0x06, at);
  ASSERT_EQ(std::vector<std::uint8_t>(awaited.begin(), awaited.end()), q2.bytes);
  Message r2 = response(3, 0x06, at, 4, 2);
  p.add(2, r2, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].outcome, Outcome::timeout);  // q0, expired first
  EXPECT_EQ(out[1].outcome, Outcome::ok);
  EXPECT_EQ(out[1].request_number, 3u);
  EXPECT_EQ(std::vector<std::uint8_t>(awaited.begin(), awaited.end()), q2.bytes);
  EXPECT_TRUE(p.awaited_request(2, 3, 0x06, at).empty());
}

// A request still waiting at the end (input over, -c, a signal) may have had its reply on the way:
// it is `pending`, not a timeout (it once made an unanswered-request finding 15 ms after it was
// sent with a 1 s timeout).
TEST(Pairer, FinishClosesPendingRequests) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q0 = request(1, 0x03, 0, 1, 0);
  p.add(0, q0, out);
  Message q1 = request(2, 0x04, kMs, 2, 1);
  p.add(1, q1, out);
  EXPECT_TRUE(out.empty());
  p.finish(out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].outcome, Outcome::pending);
  EXPECT_EQ(out[0].request_number, 1u);
  EXPECT_EQ(out[0].detail, "capture ended before a reply");
  EXPECT_EQ(out[1].outcome, Outcome::pending);
  EXPECT_EQ(out[1].request_number, 2u);
  EXPECT_EQ(out[1].channel, 1);
  EXPECT_FALSE(p.awaiting_reply(0, 1, 0x03, kMs));

  // A second finish has nothing left.
  std::vector<Transaction> again;
  p.finish(again);
  EXPECT_TRUE(again.empty());
}

TEST(Pairer, LinksAreIsolated) {
  Pairer p(options());
  std::vector<Transaction> out;
  // Same address and function on two links: a request on link 1 does not end link 0's.
  Message q0 = request(1, 0x03, 0, 1, 0);
  p.add(0, q0, out);
  Message q1 = request(1, 0x03, 2 * kMs, 2, 1);
  p.add(1, q1, out);
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(p.awaiting_reply(0, 1, 0x03, 3 * kMs));
  EXPECT_TRUE(p.awaiting_reply(1, 1, 0x03, 3 * kMs));

  // Link 1's reply pairs with link 1's request, even though link 0's is older.
  Message r1 = response(1, 0x03, request_end(2 * kMs) + 4 * kMs, 3, 1);
  p.add(1, r1, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::ok);
  EXPECT_EQ(out[0].request_number, 2u);
  EXPECT_EQ(out[0].channel, 1);
  EXPECT_EQ(out[0].latency, 4 * kMs);
  EXPECT_TRUE(p.awaiting_reply(0, 1, 0x03, 10 * kMs));
  EXPECT_FALSE(p.awaiting_reply(1, 1, 0x03, 10 * kMs));

  // A reply on link 1 now is unsolicited although link 0 still waits for the same one.
  Message stray = response(1, 0x03, 11 * kMs, 4, 1);
  p.add(1, stray, out);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[1].outcome, Outcome::unsolicited);
  EXPECT_TRUE(p.awaiting_reply(0, 1, 0x03, 12 * kMs));

  Message r0 = response(1, 0x03, 13 * kMs, 5, 0);
  p.add(0, r0, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[2].outcome, Outcome::ok);
  EXPECT_EQ(out[2].request_number, 1u);
  EXPECT_EQ(out[2].latency, 13 * kMs - request_end(0));
}

TEST(Pairer, MaxPendingBoundsTheQueue) {
  Pairer p(options(1000 * kMs, 2));
  std::vector<Transaction> out;
  // One request in flight per link; three links, room for two.
  Message q0 = request(1, 0x03, 0, 1);
  p.add(0, q0, out);
  Message q1 = request(2, 0x03, kMs, 2);
  p.add(1, q1, out);
  EXPECT_TRUE(out.empty());
  Message q2 = request(3, 0x03, 2 * kMs, 3);
  p.add(2, q2, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::timeout);
  EXPECT_EQ(out[0].request_number, 1u);  // the oldest is dropped
  EXPECT_EQ(out[0].detail, "dropped: too many requests in flight");
  EXPECT_FALSE(p.awaiting_reply(0, 1, 0x03, 3 * kMs));
  EXPECT_TRUE(p.awaiting_reply(1, 2, 0x03, 3 * kMs));
  EXPECT_TRUE(p.awaiting_reply(2, 3, 0x03, 3 * kMs));

  std::vector<Transaction> rest;
  p.finish(rest);
  ASSERT_EQ(rest.size(), 2u);
  EXPECT_EQ(rest[0].request_number, 2u);
  EXPECT_EQ(rest[1].request_number, 3u);
}

TEST(Pairer, MessagesWithoutDirectionAreIgnored) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(1, 0x03, 0, 1);
  p.add(0, q, out);
  Message m = make(Direction::unknown, 1, 0x03, 20 * kMs, 3, 2);
  p.add(0, m, out);
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(p.awaiting_reply(0, 1, 0x03, 21 * kMs));
}

// Issue 37 §6: a reply with a bad checksum was counted an `ok` transaction.
TEST(Pairer, BadChecksumReplyIsBadReplyNotOk) {
  Pairer p(options());
  std::vector<Transaction> out;
  Message q = request(1, 0x03, 0, 1);
  q.checksum.verdict = ChecksumVerdict::good;
  p.add(0, q, out);
  Message r = response(1, 0x03, request_end(0) + 4 * kMs, 2);
  r.checksum.verdict = ChecksumVerdict::bad;
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::bad_reply);
  EXPECT_EQ(outcome_id(out[0].outcome), "bad_reply");
  // It still answers its request: the request is closed and the latency measured.
  EXPECT_EQ(out[0].request_number, 1u);
  EXPECT_EQ(out[0].latency, 4 * kMs);
  EXPECT_FALSE(p.awaiting_reply(0, 1, 0x03, request_end(0) + 5 * kMs));
  // A corrupted exception reply is a bad reply too; a swapped CRC (data intact) is not.
  Message q2 = request(1, 0x03, 100 * kMs, 3);
  p.add(0, q2, out);
  Message e = response(1, 0x83, request_end(100 * kMs) + 2 * kMs, 4);
  e.checksum.verdict = ChecksumVerdict::bad;
  p.add(0, e, out);
  Message q3 = request(1, 0x03, 200 * kMs, 5);
  p.add(0, q3, out);
  Message s = response(1, 0x03, request_end(200 * kMs) + 2 * kMs, 6);
  s.checksum.verdict = ChecksumVerdict::swapped;
  p.add(0, s, out);
  ASSERT_EQ(out.size(), 3u);
  EXPECT_EQ(out[1].outcome, Outcome::bad_reply);
  EXPECT_EQ(out[2].outcome, Outcome::ok);
}

// Issue 37 §6: `drivetap decode` has no clock (its times are made up), yet a lone request was
// reported `timeout` ("capture ended before a reply"), and two requests in a row "no reply before
// the next request". Unclocked, requests are never closed as unanswered; replies still pair.
TEST(Pairer, UnclockedDecodeNeverReportsUnanswered) {
  PairerOptions o = options(10 * kMs);
  o.clocked = false;
  Pairer p(o);
  std::vector<Transaction> out;
  Message q1 = request(1, 0x03, 0, 1);
  p.add(0, q1, out);
  Message q2 = request(2, 0x03, 500 * kMs, 2);  // far past the 10 ms timeout, and a new request
  p.add(0, q2, out);
  p.expire(2000 * kMs, out);
  EXPECT_TRUE(out.empty());
  Message r = response(2, 0x03, 3000 * kMs, 3);
  p.add(0, r, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].outcome, Outcome::ok);
  EXPECT_EQ(out[0].request_number, 2u);
  p.finish(out);
  EXPECT_EQ(out.size(), 1u) << "a request left at the end is not reported";
  // The same with a clock: both requests are reported, the first timed out, the last pending.
  Pairer clocked(options(10 * kMs));
  std::vector<Transaction> timed;
  clocked.add(0, q1, timed);
  clocked.add(0, q2, timed);
  clocked.finish(timed);
  ASSERT_EQ(timed.size(), 2u);
  EXPECT_EQ(timed[0].outcome, Outcome::timeout);
  EXPECT_EQ(timed[1].outcome, Outcome::pending);
}
