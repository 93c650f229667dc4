// The one explicit table of protocol decoders (no static self-registration).
#include "core/protocol.hpp"
#include "dissectors/danfoss_fc/fc_dissector.hpp"
#include "dissectors/easydrive/eds_dissector.hpp"
#include "dissectors/modbus/ascii_dissector.hpp"
#include "dissectors/modbus/rtu_dissector.hpp"

namespace drivetap {

const ProtocolDecoder* decoder_for(Protocol protocol) {
  static const modbus::RtuDecoder rtu;
  static const modbus::AsciiDecoder ascii;
  static const danfoss_fc::FcDecoder fc;
  static const easydrive::EdsDecoder eds;
  switch (protocol) {
    case Protocol::modbus_rtu:
      return &rtu;
    case Protocol::modbus_ascii:
      return &ascii;
    case Protocol::danfoss_fc:
      return &fc;
    case Protocol::easydrive:
      return &eds;
    case Protocol::unknown:
      break;
  }
  return nullptr;
}

Protocol protocol_from_option(std::string_view name) {
  if (name == "rtu" || name == "modbus-rtu") return Protocol::modbus_rtu;
  if (name == "ascii" || name == "modbus-ascii") return Protocol::modbus_ascii;
  if (name == "fc" || name == "danfoss-fc") return Protocol::danfoss_fc;
  if (name == "eds" || name == "easydrive") return Protocol::easydrive;
  return Protocol::unknown;
}

}  // namespace drivetap
