// Drive binding by guess (src/drive/binder.hpp): per-station evidence for each family profile.
#include "drive/binder.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivetap {
namespace {

using namespace evidence;
// A station is bound when its best profile reaches kBindScore and leads the runner-up by
// kBindMargin; rebinding needs a lead of kRebindMargin over the bound profile. A lead of 3 is
// what confidence "medium" asks (below): a family is never bound on low confidence.
constexpr double kBindScore = 2, kBindMargin = 3, kRebindMargin = 3;

// Evidence from a request in a protocol that only some families speak (family_protocol): the
// protocol itself, and each address it names (that its reader weighs) that the profile names.
double family_protocol_evidence(const DriveProfile& p, Direction direction,
                                const DriveRecords& records) {
  if (direction != Direction::request) return 0;
  double score = kOwnProtocol;
  for (const DriveRecord& r : records.records)
    if (r.type == DriveRecordType::access && r.weighed && p.find(r.kind, r.first)) score += kNamed;
  return score;
}

// Evidence from a telegram of a protocol every device speaks: its function code, the addresses
// it reads and writes and how many, the exception codes of its replies.
double addressing_evidence(const DriveProfile& p, AddressEvidence& addresses, Direction direction,
                           const DriveRecords& records) {
  double score = 0;
  if (direction == Direction::response) {
    for (const DriveRecord& r : records.records) {
      if (r.type != DriveRecordType::exception) continue;
      if (p.exceptions.count(r.code))
        score += kNamed;
      else if (r.code > 4)
        score += kUnknown;  // non-standard code the family does not list
    }
    return score;
  }
  if (direction != Direction::request) return 0;
  if (records.function >= 0 && !p.functions.empty() &&
      std::find(p.functions.begin(), p.functions.end(), records.function) == p.functions.end())
    score += kRefused;
  for (const DriveRecord& r : records.records) {
    if (r.type != DriveRecordType::access || !r.weighed) continue;
    score += addresses.sum(r.kind, r.first, r.count);
    const bool registers = r.kind == RegisterKind::holding || r.kind == RegisterKind::input;
    if (registers && r.op == AccessOp::read && p.max_read_registers &&
        r.count > static_cast<std::uint32_t>(*p.max_read_registers))
      score += kRefused;
    if (registers && r.op == AccessOp::write && p.max_write_registers &&
        r.count > static_cast<std::uint32_t>(*p.max_write_registers))
      score += kRefused;
  }
  return score;
}

double telegram_evidence(const DriveProfile& p, AddressEvidence& addresses, Direction direction,
                         const DriveRecords& records) {
  return records.family_protocol ? family_protocol_evidence(p, direction, records)
                                 : addressing_evidence(p, addresses, direction, records);
}

// The memo key of a request's evidence (what addressing_evidence() reads of it), if it has one:
// its function and its one access at most.
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

// "the first 40 of 9379 frames" of a decided station: its evidence is what those showed.
std::string decided_over(const DriveBinder::Station& st) {
  return fmt::format("the first {} of {} frames", st.decided_after, st.frames);
}

}  // namespace

std::span<const double> DriveBinder::request_evidence(std::uint64_t key,
                                                      const DriveRecords& records) {
  if (request_evidence_.size() >= kMaxRememberedRequests) {
    request_evidence_.clear();
    evidence_pool_.clear();
  }
  const auto [it, fresh] = request_evidence_.try_emplace(key, evidence_pool_.size());
  if (fresh)
    for (std::size_t i = 0; i < candidates_.size(); ++i)
      evidence_pool_.push_back(
          telegram_evidence(*candidates_[i], addresses_[i], Direction::request, records));
  return std::span<const double>(evidence_pool_).subspan(it->second, candidates_.size());
}

DriveBinder::DriveBinder(std::vector<const DriveProfile*> candidates)
    : candidates_(std::move(candidates)) {
  for (const DriveProfile* p : candidates_) {
    addresses_.emplace_back(*p);
    std::uint32_t mask = 0;
    for (const Protocol protocol : p->protocols) mask |= protocol_bit(protocol);
    protocols_.push_back(mask);
  }
}

const DriveProfile* DriveBinder::bound(std::size_t link, int address) const {
  const auto it = stations_.find({link, address});
  if (it == stations_.end() || it->second.bound < 0) return nullptr;
  return candidates_[static_cast<std::size_t>(it->second.bound)];
}

DriveBinder::Station& DriveBinder::station_of(std::size_t link, int address) {
  if (address >= kIndexedAddresses) return stations_[{link, address}];
  const std::size_t at = link * kIndexedAddresses + static_cast<std::size_t>(address);
  if (at >= station_index_.size()) station_index_.resize(at + 1, nullptr);
  Station*& station = station_index_[at];
  if (!station) station = &stations_[{link, address}];
  return *station;
}

std::pair<int, std::optional<double>> DriveBinder::best_of(const Station& st) const {
  int best = -1;
  std::optional<double> second;
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    if (st.excluded[i]) continue;
    const double s = st.score[i];
    if (best < 0 || s > st.score[static_cast<std::size_t>(best)]) {
      if (best >= 0) second = st.score[static_cast<std::size_t>(best)];
      best = static_cast<int>(i);
    } else if (!second || s > *second) {
      second = s;
    }
  }
  return {best, second};
}

std::string DriveBinder::evidence(const Station& st) const {
  const auto [best, second] = best_of(st);
  auto name_with = [&](double score, int skip) -> std::string {
    for (std::size_t i = 0; i < candidates_.size(); ++i)
      if (static_cast<int>(i) != skip && !st.excluded[i] && st.score[i] == score)
        return fmt::format("{} {:+g}", candidates_[i]->name, score);
    return {};
  };
  if (st.bound < 0) {
    if (best < 0) return "no family profile speaks its protocol at its address";
    const double top = st.score[static_cast<std::size_t>(best)];
    if (top <= 0)
      return st.decided_after == 0
                 ? fmt::format("no family profile fits its traffic (best {})", name_with(top, -1))
                 : fmt::format("no family profile fits its traffic (best {} over {}, decided)",
                               name_with(top, -1), decided_over(st));
    return fmt::format("too little evidence to choose ({}{})", name_with(top, -1),
                       second ? ", " + name_with(*second, best) : std::string());
  }
  const double own = st.score[static_cast<std::size_t>(st.bound)];
  std::string runner = "no other family speaks its protocol at its address";
  if (second)
    runner =
        "next best " +
        name_with(best == st.bound ? *second : st.score[static_cast<std::size_t>(best)], st.bound);
  const std::string frames = st.decided_after == 0
                                 ? fmt::format("{} frame{}", st.frames, st.frames == 1 ? "" : "s")
                                 : decided_over(st) + " (decided)";
  return fmt::format("auto, confidence {}: evidence {:+g} over {}, {}", st.confidence, own, frames,
                     runner);
}

const DriveProfile* DriveBinder::learn_bound(std::size_t link, TelegramDriveRecords& telegram,
                                             std::optional<BusEvent>& event) {
  const TelegramHead& m = telegram.telegram();
  // (Stations are made only below: no station has an address of 0 or less.)
  if (m.address <= 0 || candidates_.empty()) return nullptr;  // broadcasts bind nothing
  if (!good_telegram(m)) return bound(link, m.address);
  Station& st = station_of(link, m.address);
  const auto bound_now = [&]() -> const DriveProfile* {
    return st.bound >= 0 ? candidates_[static_cast<std::size_t>(st.bound)] : nullptr;
  };
  if (st.score.empty()) {
    st.score.assign(candidates_.size(), 0);
    st.excluded.assign(candidates_.size(), 0);
  }
  ++st.frames;
  if (st.decided_after != 0) {
    if (st.protocol == m.protocol) return bound_now();
    st.decided_after = 0;  // another protocol: the evidence is weighed again
  }
  const DriveRecords& records = telegram.get();
  // The same poll repeats all day: a request's evidence is remembered.
  const std::optional<std::uint64_t> key =
      m.direction == Direction::request ? request_key(records) : std::nullopt;
  // A telegram with nothing to weigh scores nothing: of a reply only an exception in a protocol
  // every device speaks weighs (telegram_evidence()); a reply read with its request carries the
  // values it reads as well, which weigh nothing.
  const bool weighs = m.direction == Direction::request
                          ? key || !records.records.empty() || records.family_protocol
                          : m.direction == Direction::response && !records.family_protocol &&
                                std::ranges::any_of(records.records, [](const DriveRecord& r) {
                                  return r.type == DriveRecordType::exception;
                                });
  const std::span<const double> request_scores =
      key ? request_evidence(*key, records) : std::span<const double>();
  if (st.protocol != m.protocol || st.protocol_bit == 0) {
    st.protocol = m.protocol;
    st.protocol_bit = protocol_bit(m.protocol);
  }
  const std::uint32_t protocol = st.protocol_bit;
  for (std::size_t i = 0; i < candidates_.size(); ++i) {
    const DriveProfile& p = *candidates_[i];
    if (!(protocols_[i] & protocol) || m.address < p.address_min || m.address > p.address_max) {
      st.excluded[i] = 1;
      continue;
    }
    if (key)
      st.score[i] += request_scores[i];
    else if (weighs)
      st.score[i] += telegram_evidence(p, addresses_[i], m.direction, records);
  }
  const auto [best, second] = best_of(st);
  if (best < 0) return bound_now();
  const double lead = st.score[static_cast<std::size_t>(best)] - second.value_or(0);
  const double top = st.score[static_cast<std::size_t>(best)];
  bool changed = false;
  if (st.bound < 0) {
    changed = top >= kBindScore && lead >= kBindMargin;
  } else if (best != st.bound) {
    changed = top - st.score[static_cast<std::size_t>(st.bound)] >= kRebindMargin;
  }
  if (st.bound >= 0 && st.excluded[static_cast<std::size_t>(st.bound)]) changed = true;
  // A bound profile whose own evidence has sunk as low as decides a station generic is let go.
  if (st.bound >= 0 && st.score[static_cast<std::size_t>(st.bound)] <= -kDecidedLead)
    changed = true;
  const int was = st.bound;
  if (changed) st.bound = top >= kBindScore ? best : -1;
  if (st.bound >= 0) {
    const double own = st.score[static_cast<std::size_t>(st.bound)];
    const double margin = own - (best == st.bound ? second.value_or(0) : top);
    st.confidence = own >= 8 && margin >= 6            ? "high"
                    : own >= kBindScore && margin >= 3 ? "medium"
                                                       : "low";
    if (margin >= kDecidedLead) st.decided_after = st.frames;
  } else if (top <= -kDecidedLead) {
    st.decided_after = st.frames;
  }
  if (!changed) return bound_now();
  BusEvent& e = event.emplace();
  e.time = m.start;
  e.channel = m.channel;
  e.kind = "drive_bound";
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
                 : fmt::format("drive {}: {}", m.address, evidence(st));
  return bound_now();
}

}  // namespace drivetap
