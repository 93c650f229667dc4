// Drive binding by evidence (src/drive/binder.hpp): each paired transaction judged for each
// family profile.
#include "drive/binder.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivetap {
namespace {

using enum BindingReason;
using CheckedRegister = DriveBinder::CheckedRegister;

std::vector<CheckedRegister> checked_registers(const DriveProfile& p) {
  std::vector<CheckedRegister> out;
  for (const RegisterDef& r : p.registers) {
    if (r.kind != RegisterKind::holding && r.kind != RegisterKind::input) continue;
    if (r.words != 1) continue;  // (no built-in profile constrains a 32-bit value)
    CheckedRegister c{r.kind, r.address};
    c.status = r.role == RegisterRole::status;
    std::uint32_t described = 0;
    for (const RegisterBit& b : r.bits) described |= 1u << b.bit;
    if (!r.enum_name.empty()) {
      const auto table = p.enums.find(r.enum_name);
      if (table == p.enums.end()) continue;
      c.table = &table->second;
      c.flag_bits = described;
    } else if (!r.bits.empty()) {
      for (const std::vector<int>* bits :
           {&r.state.run, &r.state.reset, &r.state.running, &r.state.forward, &r.state.reverse,
            &r.state.fault, &r.state.warning, &r.state.ready})
        for (int b : *bits) described |= 1u << b;
      c.bit_mask = described;
    } else {
      continue;
    }
    out.push_back(c);
  }
  std::ranges::sort(out, {}, &CheckedRegister::key);
  return out;
}

// Judges the values `values` of `kind` from `first` against the registers `checked`.
void judge_values(std::span<const CheckedRegister> checked, RegisterKind kind, std::uint32_t first,
                  std::span<const std::uint32_t> values, DriveBinder::Judgement& j) {
  if (values.empty() || checked.empty()) return;
  const CheckedRegister probe{kind, first};
  auto it = std::ranges::lower_bound(checked, probe.key(), {}, &CheckedRegister::key);
  for (; it != checked.end() && it->kind == kind && it->address - first < values.size(); ++it) {
    const std::uint32_t v = values[it->address - first];
    if (it->table) {
      if (!it->table->count(v & ~it->flag_bits))
        j.denied |= reason_bit(value_outside_table);
      else if (v != 0)
        j.fitted |= reason_bit(table_value);
    } else if (v & ~it->bit_mask) {
      j.denied |= reason_bit(undescribed_bits);
    } else if (v != 0 && it->status) {
      j.fitted |= reason_bit(described_bits);
    }
  }
}

// What a request in a protocol every device speaks shows of a family's addressing: its function
// code, the addresses it reads and writes and how many.
DriveBinder::Judgement addressing(const DriveProfile& p, AddressEvidence& addresses,
                                  const DriveRecords& records) {
  DriveBinder::Judgement j;
  if (records.function >= 0 && !p.functions.empty() &&
      std::find(p.functions.begin(), p.functions.end(), records.function) == p.functions.end())
    j.denied |= reason_bit(refused_function);
  for (const DriveRecord& r : records.records) {
    if (r.type != DriveRecordType::access || !r.weighed) continue;
    const double sum = addresses.sum(r.kind, r.first, r.count);
    if (sum < 0) j.denied |= reason_bit(unknown_addresses);
    if (sum > 0) j.fitted |= reason_bit(named_addresses);
    const bool registers = r.kind == RegisterKind::holding || r.kind == RegisterKind::input;
    if (registers && r.op == AccessOp::read && p.max_read_registers &&
        r.count > static_cast<std::uint32_t>(*p.max_read_registers))
      j.denied |= reason_bit(refused_size);
    if (registers && r.op == AccessOp::write && p.max_write_registers &&
        r.count > static_cast<std::uint32_t>(*p.max_write_registers))
      j.denied |= reason_bit(refused_size);
  }
  return j;
}

// The memo key of a request's addressing (what addressing() reads of it), if it has one: its
// function and its one access at most.
std::optional<std::uint64_t> request_key(const DriveRecords& records) {
  if (records.family_protocol || records.function < 0 || records.records.size() > 1) return {};
  std::uint64_t key = static_cast<std::uint64_t>(records.function & 0xFF) << 48;
  if (records.records.empty()) return key;
  const DriveRecord& r = records.records.front();
  if (r.type != DriveRecordType::access) return key;  // (an exception says nothing of a request)
  if (r.count > 0xFFFF) return {};
  return key | std::uint64_t{1} << 63 | static_cast<std::uint64_t>(r.weighed) << 62 |
         static_cast<std::uint64_t>(r.op) << 59 | static_cast<std::uint64_t>(r.kind) << 56 |
         static_cast<std::uint64_t>(r.count) << 32 | r.first;
}

// "its own protocol, a value the manual's table lists" for the reasons in `bits`.
std::string reasons(std::uint16_t bits) {
  std::string out;
  for (unsigned r = 0; r <= static_cast<unsigned>(unlisted_exception); ++r) {
    if (!(bits & (1u << r))) continue;
    if (!out.empty()) out += ", ";
    out += DriveBinder::reason_text(static_cast<BindingReason>(r));
  }
  return out;
}

std::string plural(std::uint64_t n, std::string_view one, std::string_view many) {
  return fmt::format("{} {}", n, n == 1 ? one : many);
}

}  // namespace

std::string_view DriveBinder::reason_text(BindingReason r) {
  switch (r) {
    case own_protocol:
      return "its own protocol";
    case vendor_exception:
      return "an exception code the manual lists";
    case table_value:
      return "a value the manual's table lists";
    case described_bits:
      return "a status word setting only bits the manual describes";
    case named_addresses:
      return "addresses the manual names";
    case unknown_addresses:
      return "addresses it does not have";
    case refused_function:
      return "a function code it refuses";
    case refused_size:
      return "a request size it refuses";
    case value_outside_table:
      return "a value outside the manual's table";
    case undescribed_bits:
      return "a bit the manual does not describe";
    case unlisted_exception:
      return "an exception code it does not list";
  }
  return "?";
}

std::span<const DriveBinder::Judgement> DriveBinder::request_judgements(
    std::uint64_t key, const DriveRecords& records) {
  if (request_judgements_.size() >= kMaxRememberedRequests) {
    request_judgements_.clear();
    judgement_pool_.clear();
  }
  const auto [it, fresh] = request_judgements_.try_emplace(key, judgement_pool_.size());
  if (fresh)
    for (std::size_t i = 0; i < candidates_.size(); ++i)
      judgement_pool_.push_back(addressing(*candidates_[i], addresses_[i], records));
  return std::span<const Judgement>(judgement_pool_).subspan(it->second, candidates_.size());
}

DriveBinder::DriveBinder(std::vector<const DriveProfile*> candidates)
    : candidates_(std::move(candidates)) {
  for (const DriveProfile* p : candidates_) {
    addresses_.emplace_back(*p);
    std::uint32_t mask = 0;
    for (const Protocol protocol : p->protocols) mask |= protocol_bit(protocol);
    protocols_.push_back(mask);
    checked_.push_back(checked_registers(*p));
  }
}

const DriveProfile* DriveBinder::bound(std::size_t link, int address) const {
  const auto it = stations_.find({link, address});
  if (it == stations_.end() || it->second.bound < 0) return nullptr;
  return candidates_[static_cast<std::size_t>(it->second.bound)];
}

bool DriveBinder::sure(std::size_t link, int address) const {
  const Station* st = nullptr;
  const std::size_t at = link * kIndexedAddresses + static_cast<std::size_t>(address);
  if (address >= 0 && address < kIndexedAddresses && at < station_index_.size()) {
    st = station_index_[at];
  } else if (const auto it = stations_.find({link, address}); it != stations_.end()) {
    st = &it->second;
  }
  return st && st->bound >= 0 && st->confidence == "high";
}

DriveBinder::Station& DriveBinder::station_of(std::size_t link, int address) {
  if (address >= kIndexedAddresses) return stations_[{link, address}];
  const std::size_t at = link * kIndexedAddresses + static_cast<std::size_t>(address);
  if (at >= station_index_.size()) station_index_.resize(at + 1, nullptr);
  Station*& station = station_index_[at];
  if (!station) station = &stations_[{link, address}];
  return *station;
}

bool DriveBinder::qualifies(const Tally& t) const {
  return t.alone >= kBindTransactions && std::uint64_t{t.contradicts} * 4 <= t.fits;
}

std::pair<int, int> DriveBinder::best_of(const Station& st) const {
  int best = -1, second = -1;
  const auto better = [&](std::size_t a, int b) {
    if (b < 0) return true;
    const Tally& x = st.tally[a];
    const Tally& y = st.tally[static_cast<std::size_t>(b)];
    if (x.alone != y.alone) return x.alone > y.alone;
    if (x.fits != y.fits) return x.fits > y.fits;
    return x.contradicts < y.contradicts;
  };
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    if (st.excluded[i]) continue;
    if (better(i, best)) {
      second = best;
      best = static_cast<int>(i);
    } else if (better(i, second)) {
      second = static_cast<int>(i);
    }
  }
  return {best, second};
}

std::string DriveBinder::evidence(const Station& st) const {
  const auto [best, second] = best_of(st);
  const auto account = [&](int c) {
    const Tally& t = st.tally[static_cast<std::size_t>(c)];
    std::string s = fmt::format("{}: {} only it explains", candidates_[c]->name,
                                plural(t.alone, "transaction", "transactions"));
    if (t.fitted & kTellingReasons) s += " (" + reasons(t.fitted & kTellingReasons) + ")";
    s += fmt::format(", {} contradicting", t.contradicts);
    if (t.denied) s += " (" + reasons(t.denied) + ")";
    return s;
  };
  const std::string over =
      st.decided_after == 0
          ? fmt::format("over {}",
                        plural(st.transactions, "paired transaction", "paired transactions"))
          : fmt::format("over {} paired transactions, decided after {} of {} frames",
                        st.transactions, st.decided_after, st.frames);
  if (st.bound < 0) {
    if (best < 0) return "no family profile speaks its protocol at its address";
    if (st.transactions == 0)
      return "no reply paired with its request yet: requests and replies alone prove nothing";
    const Tally& t = st.tally[static_cast<std::size_t>(best)];
    const std::string why =
        t.alone == 0 ? "no family profile fits its traffic"
        : std::uint64_t{t.contradicts} * 4 > t.fits
            ? "its traffic contradicts the family that fits it"
            : fmt::format(
                  "too little evidence to choose (binding needs {} transactions only one "
                  "family explains)",
                  kBindTransactions);
    return fmt::format("{} ({}; best {})", why, over, account(best));
  }
  std::string runner = "no other family speaks its protocol at its address";
  if (const int other = best == st.bound ? second : best; other >= 0)
    runner = "next best " + account(other);
  return fmt::format("auto, confidence {}: {}, {}; {}", st.confidence, account(st.bound), over,
                     runner);
}

const DriveProfile* DriveBinder::learn_bound(std::size_t link, TelegramDriveRecords& telegram,
                                             std::optional<BusEvent>& event) {
  const TelegramHead& m = telegram.telegram();
  // (Stations are made only below: no station has an address of 0 or less.)
  if (m.address <= 0 || candidates_.empty()) return nullptr;  // broadcasts bind nothing
  const bool good = good_telegram(m);
  if (!good && m.direction != Direction::request) return bound(link, m.address);
  if (!good) {
    // A damaged request puts aside the one before it: its reply would be this one's.
    const auto it = stations_.find({link, m.address});
    if (it != stations_.end()) it->second.has_awaiting = false;
    return bound(link, m.address);
  }
  Station& st = station_of(link, m.address);
  const auto bound_now = [&]() -> const DriveProfile* {
    return st.bound >= 0 ? candidates_[static_cast<std::size_t>(st.bound)] : nullptr;
  };
  if (st.tally.empty()) {
    st.tally.assign(candidates_.size(), {});
    st.excluded.assign(candidates_.size(), 0);
    st.awaiting.assign(candidates_.size(), {});
  }
  ++st.frames;
  if (st.decided_after != 0) {
    if (st.protocol == m.protocol) return bound_now();
    st.decided_after = 0;  // another protocol: the evidence is weighed again
  }
  if (st.protocol != m.protocol || st.protocol_bit == 0) {
    st.protocol = m.protocol;
    st.protocol_bit = protocol_bit(m.protocol);
  }
  const std::uint32_t protocol = st.protocol_bit;
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    const DriveProfile& p = *candidates_[i];
    if (!(protocols_[i] & protocol) || m.address < p.address_min || m.address > p.address_max)
      st.excluded[i] = 1;
  }
  const std::vector<std::vector<CheckedRegister>>& checked = checked_;
  if (m.direction == Direction::request) {
    const DriveRecords& records = telegram.get();
    const std::optional<std::uint64_t> key = request_key(records);
    const std::span<const Judgement> addressing_of =
        key ? request_judgements(*key, records) : std::span<const Judgement>();
    for (std::size_t i = 0; i < candidates_.size(); ++i) {
      if (st.excluded[i]) continue;
      Judgement& j = st.awaiting[i];
      if (records.family_protocol)
        j = {reason_bit(own_protocol), 0};
      else
        j = key ? addressing_of[i] : addressing(*candidates_[i], addresses_[i], records);
      // The values it writes, in both directions: a control word sets only described bits.
      if (!records.family_protocol)
        for (const DriveRecord& r : records.records)
          if (r.type == DriveRecordType::access && r.op == AccessOp::write)
            judge_values(checked[i], r.kind, r.first, records.values_of(r), j);
    }
    st.has_awaiting = true;
    return bound_now();
  }
  // A reply: weighed only with the request it answers, the one this station sent last.
  if (m.direction != Direction::response || !telegram.answers_request() || !st.has_awaiting)
    return bound_now();
  st.has_awaiting = false;
  const DriveRecords& records = telegram.get();
  if (records.not_the_answer) return bound_now();  // (not the answer: it proves nothing)
  ++st.transactions;
  // A drive refuses with an exception what it does not have: then the request's addresses,
  // function and size contradict nothing.
  const bool refused = std::ranges::any_of(
      records.records, [](const DriveRecord& r) { return r.type == DriveRecordType::exception; });
  constexpr std::uint16_t kRefusable =
      reason_bit(unknown_addresses) | reason_bit(refused_function) | reason_bit(refused_size);
  std::size_t fitting = 0;
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    if (st.excluded[i]) continue;
    const DriveProfile& p = *candidates_[i];
    Judgement& j = st.awaiting[i];
    if (refused) j.denied &= static_cast<std::uint16_t>(~kRefusable);
    if (!records.family_protocol)
      for (const DriveRecord& r : records.records) {
        if (r.type == DriveRecordType::exception) {
          if (p.exceptions.count(r.code) && r.code > 4)
            j.fitted |= reason_bit(vendor_exception);
          else if (r.code > 4)
            j.denied |= reason_bit(unlisted_exception);
        } else if (r.type == DriveRecordType::access && r.op == AccessOp::value) {
          judge_values(checked[i], r.kind, r.first, records.values_of(r), j);
        }
      }
    if (!(j.denied & kContradictingReasons) && (j.fitted & kTellingReasons)) ++fitting;
  }
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    if (st.excluded[i]) continue;
    const Judgement& j = st.awaiting[i];
    Tally& t = st.tally[i];
    t.denied |= j.denied;
    if (j.denied & kContradictingReasons) {
      ++t.contradicts;
    } else if (j.fitted & kTellingReasons) {
      ++t.fits;
      t.fitted |= j.fitted;
      if (fitting == 1) ++t.alone;
    }
  }
  const auto [best, second] = best_of(st);
  const int was = st.bound;
  if (st.bound >= 0) {
    const Tally& own = st.tally[static_cast<std::size_t>(st.bound)];
    if (st.excluded[static_cast<std::size_t>(st.bound)] || !qualifies(own)) {
      st.bound = -1;
    } else if (best != st.bound && qualifies(st.tally[static_cast<std::size_t>(best)]) &&
               st.tally[static_cast<std::size_t>(best)].alone >= own.alone + kBindTransactions) {
      st.bound = best;
    }
  }
  if (st.bound < 0 && best >= 0 && qualifies(st.tally[static_cast<std::size_t>(best)]) &&
      (second < 0 || st.tally[static_cast<std::size_t>(second)].alone <
                         st.tally[static_cast<std::size_t>(best)].alone))
    st.bound = best;
  if (st.bound >= 0) {
    const Tally& own = st.tally[static_cast<std::size_t>(st.bound)];
    st.confidence =
        own.alone >= kHighTransactions && std::uint64_t{own.contradicts} * 10 <= own.alone
            ? "high"
            : "medium";
    if (own.alone >= kDecidedTransactions && own.contradicts == 0) st.decided_after = st.frames;
  } else {
    bool settled = best >= 0;
    for (std::size_t i = 0; i < candidates_.size(); ++i)
      if (!st.excluded[i] &&
          (st.tally[i].contradicts < kDecidedContradictions || st.tally[i].alone > 0))
        settled = false;
    if (settled) st.decided_after = st.frames;
  }
  if (st.bound == was) return bound_now();
  BusEvent& e = event.emplace();
  e.time = m.start;
  e.channel = m.channel;
  e.kind = EventKind::drive_bound;
  e.protocol = m.protocol;
  e.address = m.address;
  e.frame = m.number;
  e.confidence = st.bound >= 0 ? st.confidence : "low";
  e.profile = st.bound >= 0 ? candidates_[static_cast<std::size_t>(st.bound)]->id : "generic";
  e.to = e.profile;
  if (was >= 0) e.from = candidates_[static_cast<std::size_t>(was)]->id;
  e.detail = st.bound >= 0
                 ? fmt::format("drive {} bound to {} ({})", m.address,
                               candidates_[static_cast<std::size_t>(st.bound)]->name, evidence(st))
                 : fmt::format("drive {} let go: {}", m.address, evidence(st));
  return bound_now();
}

}  // namespace drivetap
