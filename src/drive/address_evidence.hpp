// What the addresses of a request say for one family profile (src/drive/binder.hpp's evidence):
// the weights, and a table that weighs a request's addresses in a few lookups.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/drive_records.hpp"
#include "drive/profile.hpp"

namespace drivetap {

namespace evidence {
// A register the family's manual names: +1; an address only its parameter addressing rule
// explains: +0.5; an address the family does not have: -1; a function code or a request size the
// family refuses: -2; a vendor exception code the family lists: +1, one it does not: -1. A
// request in a protocol only some families speak (DriveRecords::family_protocol): +2 for each
// family speaking it, +1 for each address it names that the family names (a protocol every
// device speaks, as Modbus, earns nothing by itself).
inline constexpr double kNamed = 1, kRuleOnly = 0.5, kUnknown = -1, kRefused = -2;
inline constexpr double kOwnProtocol = 2;
inline constexpr std::uint32_t kMaxAddressesPerRequest = 32;  // one request's evidence is bounded
}  // namespace evidence

// The evidence of the addresses [start, start + count) (at most kMaxAddressesPerRequest) for one
// profile. Each 16-bit address's weight is kept as running sums within blocks of 256 addresses,
// a block worked out when a request first touches it: traffic that never repeats a request
// (random ranges on a plant bus) would otherwise search the profile twice for every address of
// every candidate.
class AddressEvidence {
 public:
  explicit AddressEvidence(const DriveProfile& profile) : profile_(&profile) {}

  double sum(RegisterKind kind, std::uint32_t start, std::uint32_t count);
  // The same, address by address: the definition the table keeps.
  [[nodiscard]] double walk(RegisterKind kind, std::uint32_t start, std::uint32_t count) const;

 private:
  static constexpr std::uint32_t kAddresses = 0x10000, kBlock = 256;
  struct Table {
    std::vector<std::int32_t> running;  // doubled weights of the block's addresses up to this one
    std::vector<std::uint8_t> built;    // per block
  };
  std::int32_t running(Table& t, RegisterKind kind, std::uint32_t address);

  const DriveProfile* profile_;
  std::array<Table, 6> tables_;  // by RegisterKind
};

}  // namespace drivetap
