// Evidence of a request's addresses for one profile (src/drive/address_evidence.hpp).
#include "drive/address_evidence.hpp"

#include <algorithm>

namespace drivetap {
namespace {

using namespace evidence;

bool covers(const DriveProfile& p, RegisterKind kind, std::uint32_t address) {
  if (p.find(kind, address)) return true;
  // The low word of a two-word register.
  const RegisterDef* prev = address ? p.find(kind, address - 1) : nullptr;
  return prev && prev->words == 2;
}

// The weight of one address, doubled (every weight is a multiple of 0.5, so the sums are exact).
// `first`: the first address of its request (the second register of a 32-bit parameter counts
// only after it).
std::int32_t doubled_weight(const DriveProfile& p, RegisterKind kind, std::uint32_t address,
                            bool first) {
  if (covers(p, kind, address)) return 2 * kNamed;
  if (kind != RegisterKind::holding) return 2 * kUnknown;
  if (const auto number = p.parameter_of_register(address))
    return p.find(RegisterKind::parameter, *number) ? 2 * kNamed : 2 * kRuleOnly;
  if (!first && p.parameter_of_register(address - 1)) return 2 * kRuleOnly;
  return 2 * kUnknown;
}

}  // namespace

double AddressEvidence::walk(RegisterKind kind, std::uint32_t start, std::uint32_t count) const {
  std::int32_t total = 0;
  for (std::uint32_t i = 0; i < count && i < kMaxAddressesPerRequest; ++i)
    total += doubled_weight(*profile_, kind, start + i, i == 0);
  return total / 2.0;
}

double AddressEvidence::sum(RegisterKind kind, std::uint32_t start, std::uint32_t count) {
  const std::uint32_t n = std::min(count, kMaxAddressesPerRequest);
  if (n == 0) return 0;
  // Addresses past the 16-bit space (parameter numbers of other protocols): one by one.
  if (std::uint64_t{start} + n > kAddresses) return walk(kind, start, n);
  Table& t = tables_[static_cast<std::size_t>(kind)];
  if (t.running.empty()) {
    t.running.resize(kAddresses);
    t.built.assign(kAddresses / kBlock, 0);
  }
  std::int32_t total = doubled_weight(*profile_, kind, start, true);
  // The addresses after the first, (start, last]: in one block or two (n <= kBlock).
  const std::uint32_t last = start + n - 1;
  if (last > start) {
    const std::int32_t up_to_last = running(t, kind, last);
    if (last / kBlock == start / kBlock) {
      total += up_to_last - running(t, kind, start);
    } else {
      const std::uint32_t block_end = (start / kBlock + 1) * kBlock - 1;
      total += running(t, kind, block_end) - running(t, kind, start) + up_to_last;
    }
  }
  return total / 2.0;
}

std::int32_t AddressEvidence::running(Table& t, RegisterKind kind, std::uint32_t address) {
  const std::uint32_t block = address / kBlock;
  if (!t.built[block]) {
    std::int32_t sum = 0;
    for (std::uint32_t a = block * kBlock; a < (block + 1) * kBlock; ++a)
      t.running[a] = sum += doubled_weight(*profile_, kind, a, false);
    t.built[block] = 1;
  }
  return t.running[address];
}

}  // namespace drivetap
