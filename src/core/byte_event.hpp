// ByteEvent: one received character, the input contract of every framer (docs/protocols.md §1).
//
// Sources (byte logs, pcapng, logic-analyser UART decoders, serial ports) all reduce to a time-
// ordered stream of ByteEvents. `time` is the start bit of the character; a character ends one
// character time later (SerialConfig::character_time()).
#pragma once

#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/printable.hpp"
#include "core/time.hpp"

namespace drivetap {

// UART error marks carried per byte (as PARMRK or a logic-analyser decoder reports them).
enum UartFlag : std::uint8_t {
  kUartParityError = 1u << 0,
  kUartFramingError = 1u << 1,
  kUartBreak = 1u << 2,
  kUartOverrun = 1u << 3,
  // The 9th data bit of a 9-bit character (logic captures only): a mark, not an error; `byte`
  // holds the low 8 bits.
  kUartNinthBit = 1u << 4,
};
// The marks that say a character was damaged or lost (the 9th data bit is none of them).
inline constexpr std::uint8_t kUartErrorFlags =
    kUartParityError | kUartFramingError | kUartBreak | kUartOverrun;

// What a line carried at the UART level, character by character (a capture's, or one decoder's
// run over samples): the characters received and those marked with each error, and, decoding
// samples, what never became a character.
struct UartCounts {
  std::uint64_t characters = 0;  // everything received, breaks included
  std::uint64_t parity_errors = 0;
  std::uint64_t framing_errors = 0;  // breaks not included
  std::uint64_t breaks = 0;
  // Sampled captures only: pulses under the glitch filter, and falling edges whose start bit was
  // gone at its centre.
  std::uint64_t glitches = 0;
  std::uint64_t false_starts = 0;

  // A character received with the UartFlag bits `flags`.
  void count_character(std::uint8_t flags) {
    ++characters;
    count_marks(flags);
  }
  // The error marks of a character counted already (UartFlag bits `flags`).
  void count_marks(std::uint8_t flags) {
    parity_errors += (flags & kUartParityError) != 0;
    framing_errors += (flags & kUartFramingError) != 0;
    breaks += (flags & kUartBreak) != 0;
  }
  // Totals of several lines or decoders.
  UartCounts& operator+=(const UartCounts& o) {
    characters += o.characters;
    parity_errors += o.parity_errors;
    framing_errors += o.framing_errors;
    breaks += o.breaks;
    glitches += o.glitches;
    false_starts += o.false_starts;
    return *this;
  }
};

using ChannelId = std::uint16_t;

struct ByteEvent {
  TimeNs time = 0;         // start bit of this character, ns
  std::uint8_t byte = 0;   // data bits as received
  std::uint8_t flags = 0;  // UartFlag bits
  ChannelId channel = 0;   // index into the ChannelTable
  // Source unit the byte came from (packet number in a pcap/pcapng file), 0 when the source
  // has none. Lets the pipeline report packets that held several frames or part of one.
  std::uint32_t origin = 0;
};

// What a channel name tells about direction on the wire.
enum class ChannelRole : std::uint8_t {
  bus,     // half-duplex tap: both directions interleaved; direction comes from content and order
  master,  // only master -> slave traffic (requests)
  slave,   // only slave -> master traffic (responses)
};

// Channels are named by the source ("bus", "m", "s", "/dev/ttyUSB0", "port1.m"). Channels that
// belong to one Modbus link share a link id, so requests on "m" pair with responses on "s":
//   "bus", "m", "s"                    -> link ""        (the default link)
//   "<name>.m", "<name>.s", "<name>"   -> link "<name>"
// "m"/"s" (or a ".m"/".s" suffix) give the role master/slave; anything else is a bus.
struct Channel {
  std::string name;
  std::string link;
  ChannelRole role = ChannelRole::bus;
  // The payload of one direction of a TCP or UDP flow, not a serial line: it joins the decode
  // only once detection finds a drive protocol on it.
  bool ip_flow = false;
};

// A channel id that names no channel: what intern() returns for a new name once the table is full.
inline constexpr ChannelId kNoChannel = 0xFFFF;

class ChannelTable {
 public:
  // Channels one run keeps apart. Sources name channels from their input (byte log columns, IP
  // flows, pcapng interfaces, logic-analyser lines), and every channel gets its own framer,
  // detection buffer and statistics: without a bound a hostile file could grow memory (and the
  // linear name lookup) without end. A real tap has a handful.
  static constexpr std::size_t kMaxChannels = 256;
  // A channel's name as printed: printable UTF-8 (src/core/printable.hpp), at most this long (a
  // pcapng if_name may run to 64 KiB, and every output line names its channel).
  static constexpr std::size_t kMaxNameBytes = 64;

  // One thread may intern (a source reading ahead on a thread of its own) while another looks
  // up the channels of the bytes it was handed: the storage is reserved once and never moves,
  // and a channel is published (size()) only once it is complete.
  ChannelTable() {
    channels_.reserve(kMaxChannels);
    given_names_.reserve(kMaxChannels);
    link_of_.reserve(kMaxChannels);
    links_.reserve(kMaxChannels);
  }
  ChannelTable(const ChannelTable&) = delete;
  ChannelTable& operator=(const ChannelTable&) = delete;

  // Returns the id of `name`, adding the channel on first use (link and role from the name);
  // kNoChannel when the name is new and the table already holds kMaxChannels.
  ChannelId intern(std::string_view name);
  // Same, with the link and role given explicitly (sources that know them, e.g. IP flows).
  ChannelId intern(std::string_view name, std::string_view link, ChannelRole role,
                   bool ip_flow = false);
  [[nodiscard]] const Channel& at(ChannelId id) const { return channels_[checked(id)]; }
  [[nodiscard]] std::size_t size() const { return size_.load(std::memory_order_acquire); }
  // Index of the link a channel belongs to (dense, 0..link_count()-1).
  [[nodiscard]] std::size_t link_index(ChannelId id) const { return link_of_[checked(id)]; }
  [[nodiscard]] std::size_t link_count() const {
    return link_count_.load(std::memory_order_acquire);
  }
  // Names that had to be escaped or shortened to print (said once, in a note), and the first.
  [[nodiscard]] std::size_t rewritten_names() const { return rewritten_; }
  [[nodiscard]] const std::string& first_rewritten_name() const { return first_rewritten_; }

 private:
  [[nodiscard]] std::size_t checked(ChannelId id) const {
    if (id >= size()) throw std::out_of_range("ChannelTable: no channel " + std::to_string(id));
    return id;
  }

  // Only intern() changes these, by push_back within the reserved capacity; readers index the
  // published part (below size_ / link_count_).
  std::vector<Channel> channels_;
  std::vector<std::string> given_names_;  // as the source gave them: the lookup's key
  std::vector<std::size_t> link_of_;
  std::vector<std::string> links_;
  std::atomic<std::size_t> size_{0};
  std::atomic<std::size_t> link_count_{0};
  std::size_t rewritten_ = 0;
  std::string first_rewritten_;
};

inline ChannelId ChannelTable::intern(std::string_view name, std::string_view link,
                                      ChannelRole role, bool ip_flow) {
  for (std::size_t i = 0; i < given_names_.size(); ++i)
    if (given_names_[i] == name) return static_cast<ChannelId>(i);
  if (channels_.size() >= kMaxChannels) return kNoChannel;
  Channel ch{printable_bounded(name, kMaxNameBytes), std::string(link), role, ip_flow};
  if (ch.name != name && rewritten_++ == 0) first_rewritten_ = ch.name;
  given_names_.emplace_back(name);
  std::size_t link_index = links_.size();
  for (std::size_t i = 0; i < links_.size(); ++i)
    if (links_[i] == ch.link) link_index = i;
  if (link_index == links_.size()) {
    links_.push_back(ch.link);
    link_count_.store(links_.size(), std::memory_order_release);
  }
  channels_.push_back(std::move(ch));
  link_of_.push_back(link_index);
  size_.store(channels_.size(), std::memory_order_release);
  return static_cast<ChannelId>(channels_.size() - 1);
}

inline ChannelId ChannelTable::intern(std::string_view name) {
  std::string_view link = name;
  if (name == "m" || name == "s" || name == "bus") {
    link = "";
  } else if (name.size() > 2 && (name.ends_with(".m") || name.ends_with(".s"))) {
    link = name.substr(0, name.size() - 2);
  }
  ChannelRole role = ChannelRole::bus;
  if (name == "m" || name.ends_with(".m")) role = ChannelRole::master;
  if (name == "s" || name.ends_with(".s")) role = ChannelRole::slave;
  return intern(name, link, role);
}

}  // namespace drivetap
