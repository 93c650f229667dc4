// Fuzzes the display filter (-Y, src/filter/display_filter.hpp, docs/reference.md "Display
// filters"): any text is compiled; a refusal must say why with its column, a compiled filter is
// evaluated on a Modbus record. Deep nesting (parentheses, '!') must be refused at its limit, not
// overflow the stack, and long chains of && and || must evaluate without recursion.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/protocol.hpp"
#include "core/protocol_desc.hpp"
#include "filter/display_filter.hpp"
#include "fuzz/fuzz_common.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace drivetap;
  // Inputs built from one repeated byte reach the nesting limit: "(((((" and "!!!!!" as the fuzzer
  // makes them, and the first byte repeated 2^k times as the seed corpus has them.
  std::string text(reinterpret_cast<const char*>(data), size);
  if (size >= 2 && data[0] == 0xFF) text = std::string(std::size_t{1} << (data[1] % 18), '(') +
                                           text.substr(2);
  std::string error;
  const std::optional<DisplayFilter> filter = DisplayFilter::compile(text, &error);
  if (!filter) {
    if (error.find(" at column ") == std::string::npos)
      fuzz::contract_broken("a refused filter without its column");
    return 0;
  }
  static ChannelTable channels;
  static const ChannelId bus = channels.intern("bus");
  Message m;
  m.frame.channel = bus;
  m.frame.number = 7;
  m.address = 2;
  m.function = 3;
  m.direction = Direction::request;
  m.protocol = Protocol(registered_protocols().front());
  m.bytes = {0x02, 0x03, 0x00, 0x10};
  RecordView r;
  r.message = &m;
  r.channels = &channels;
  r.findings = m.anomalies;
  (void)filter->matches(r);
  return 0;
}
