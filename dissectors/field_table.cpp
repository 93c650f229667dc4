// The one explicit table of every field descriptor, across all dissectors (no self-registration).
#include <vector>

#include "core/field.hpp"
#include "dissectors/danfoss_fc/fc_fields.hpp"
#include "dissectors/easydrive/eds_fields.hpp"
#include "dissectors/modbus/modbus_fields.hpp"

namespace drivetap {

std::span<const FieldDesc* const> all_field_descriptors() {
  static const std::vector<const FieldDesc*> table = [] {
    std::vector<const FieldDesc*> t;
    for (const FieldDesc* d : modbus::kAllFields) t.push_back(d);
    for (const FieldDesc* d : danfoss_fc::kAllFields) t.push_back(d);
    for (const FieldDesc* d : easydrive::kAllFields) t.push_back(d);
    return t;
  }();
  return table;
}

}  // namespace drivetap
