// Hex text input for `drivetap decode`: frames pasted from a manual or a log.
//
//   "02 03 00 00 00 04 44 3A"            one frame (spaces optional, 0x prefixes allowed)
//   "01 03 ... | 01 03 ..."              several frames: '|', ',', ';' or a newline between them
//   "0103000000018 40A0103020001..."     several frames run together: split by content
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/byte_event.hpp"
#include "core/serial_config.hpp"

namespace drivetap {

// Splits `text` into frames of bytes. On error returns nullopt and sets *error to a one-line
// reason naming the character position.
std::optional<std::vector<std::vector<std::uint8_t>>> parse_hex_frames(std::string_view text,
                                                                       std::string* error);

// An ASCII-protocol frame given as text (":010325230001B3\r\n"): escapes \r \n \t \\ and
// \xHH become their bytes; a missing terminator (`terminator`, e.g. "\r\n") is appended, as
// manuals print frames without it. Returns nullopt with *error for a bad escape.
std::optional<std::vector<std::uint8_t>> parse_text_frame(std::string_view text,
                                                          std::string_view terminator,
                                                          std::string* error);

// What kind of text one `drivetap decode` input is: ':' (a Modbus ASCII frame) or '~' (an
// Easydrive frame) by its first non-blank character, 'x' (hex bytes) otherwise, 0 when blank.
char decode_text_kind(std::string_view text);

// The frames of one `drivetap decode` input of that kind (not 0): a text frame from its first
// character on, with the protocol's terminator (":" CR LF, "~" CR) appended when missing, or the
// hex frames. nullopt with *error when refused.
std::optional<std::vector<std::vector<std::uint8_t>>> parse_decode_text(std::string_view text,
                                                                        char kind,
                                                                        std::string* error);

// Lays frames out on a synthetic time line: back-to-back characters, `gap` of silence between
// frames (the first starts at time 0). Appends to `out`.
void synthesize_events(const std::vector<std::vector<std::uint8_t>>& frames, ChannelId channel,
                       TimeNs character_time, TimeNs gap, TimeNs* clock,
                       std::vector<ByteEvent>& out);

}  // namespace drivetap
