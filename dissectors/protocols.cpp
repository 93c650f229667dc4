// The one explicit table of protocol decoders (no static self-registration).
#include "core/protocol.hpp"
#include "dissectors/modbus/rtu_dissector.hpp"

namespace drivetap {

const ProtocolDecoder* decoder_for(Protocol protocol) {
  static const modbus::RtuDecoder rtu;
  switch (protocol) {
    case Protocol::modbus_rtu:
      return &rtu;
    case Protocol::unknown:
      break;
  }
  return nullptr;
}

Protocol protocol_from_option(std::string_view name) {
  if (name == "rtu" || name == "modbus-rtu") return Protocol::modbus_rtu;
  return Protocol::unknown;
}

}  // namespace drivetap
