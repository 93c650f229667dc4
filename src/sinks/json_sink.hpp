// JSON-lines sink: one object per record; keys are the output contract in docs/formats.md "JSON
// lines". Records are gathered in a buffer and written in blocks; flush() writes what is buffered.
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "core/byte_event.hpp"
#include "core/line_buffer.hpp"
#include "core/serial_config.hpp"
#include "sinks/line_writer.hpp"
#include "sinks/sink.hpp"

namespace drivetap {

struct DriveProfile;  // drive/profile.hpp
struct RegisterDef;

// On cache lines of its own: the helpers of a ThreadedSink, one per thread, each write theirs for
// every record, and are made one after the other on the heap.
// Each record stands on its own: nothing to follow() when formatting in memory.
class alignas(kCacheLineBytes) JsonSink final : public LineFormattingSink {
 public:
  JsonSink(std::FILE* out, const ChannelTable& channels, TimeNs character_time,
           bool show_latency = true);
  void on_frame(const Message& message) override;
  void on_noise(const Frame& noise) override;
  void on_anomaly(const Anomaly& anomaly) override;
  void on_transaction(const Transaction& transaction) override;
  void on_summary(const Stats& stats) override;
  void on_event(const BusEvent& event) override;

 private:
  // One id of a frame's field tree: its descriptor, first node and number of nodes.
  struct FieldKey {
    const FieldDesc* key;  // FieldDesc::key() of the id's nodes
    std::size_t first;
    std::size_t count;
  };
  // Appends the frame's field tree as an object keyed by id (field_keys_ is its scratch).
  void append_fields_object(LineBuffer& out, const Message& m);
  // Appends the frame's `drive` object, if it has one.
  void append_drive_object(LineBuffer& out, const Message& m);
  // A register's values in the `drive` object, in pieces made once for each register of a
  // profile: ,"id":{"value": and ,"unit":"Hz","raw": (or ,"raw":), each padded to kPieceChars
  // (copied whole, cut to its size), and the decimals of its scale (decimal_scale_index()); -1
  // when its values are written the general way (another scale, or a piece too long).
  struct RegisterPieces {
    static constexpr std::size_t kPieceChars = 48;
    std::array<char, kPieceChars> key{}, tail{};
    std::uint8_t key_size = 0, tail_size = 0;
    std::int8_t decimals = -1;
  };
  struct ProfilePieces {
    const DriveProfile* profile = nullptr;
    std::vector<RegisterPieces> registers;  // by the index in the profile's register list
  };
  // The pieces of `profile`'s registers (made at its first frame).
  const RegisterPieces* pieces_for(const DriveProfile& profile) {
    return &profile == pieces_profile_ ? pieces_ : switch_pieces(profile);
  }
  const RegisterPieces* switch_pieces(const DriveProfile& profile);
  std::vector<ProfilePieces> profile_pieces_;
  const DriveProfile* pieces_profile_ = nullptr;  // the profile pieces_for() was asked for last
  const RegisterPieces* pieces_ = nullptr;        // its pieces
  const ChannelTable& channels_;
  TimeNs character_time_;
  bool show_latency_;
  std::vector<FieldKey> field_keys_;  // scratch: the ids of the frame's field tree
  // A channel's name as a JSON string (quoted at its first record: names never change).
  std::string_view quoted_channel(ChannelId id);
  std::vector<std::string> quoted_channels_;
};

// JSON string literal with escapes.
std::string json_quote(std::string_view s);
// The same appended to `out`: Out is std::string or LineBuffer (instantiated for both).
template <class Out>
void append_json_quoted(Out& out, std::string_view s);
// `s` as the inside of a JSON string (escaped, no quotes).
template <class Out>
void append_json_escaped(Out& out, std::string_view s);
// Escapes out[from..] in place, as the inside of a JSON string (std::string or LineBuffer).
template <class Out>
void escape_json_tail(Out& out, std::size_t from);

}  // namespace drivetap
