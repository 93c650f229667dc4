// The generic fields of a decoded frame record, which every protocol has: the keys of a JSON
// `frame` record (docs/formats.md "JSON lines"), declared as field descriptors so that `drivetap
// fields` lists them beside the protocols' fields, and display filters and `-T fields` can name
// them. Their ids are the JSON keys as they are (no prefix); their layer is `drivetap`.
#pragma once

#include <cstddef>
#include <iterator>
#include <string_view>

#include "core/enum_text.hpp"
#include "core/field.hpp"
#include "core/frame.hpp"

namespace drivetap {

inline constexpr FieldDesc kRecordNumber{
    "n", "Frame number", FieldType::uint, 32, {}, "The frame's number in the capture, from 1"};
inline constexpr FieldDesc kRecordTime{
    "t", "Time", FieldType::real,
    0,   {},     "Seconds from the capture's start to the start bit of the frame's first byte"};
inline constexpr FieldDesc kRecordTimeEnd{
    "t_end", "End time", FieldType::real,
    0,       {},         "Seconds to the end of the frame's last character"};
inline constexpr FieldDesc kRecordChannel{
    "channel", "Channel", FieldType::text, 0, {}, "The channel the frame came on (its name)"};
inline constexpr FieldDesc kRecordDirection{"dir", "Direction", FieldType::text,
                                            0,     {},          "request, response or unknown"};
inline constexpr FieldDesc kRecordProtocol{
    "protocol",
    "Protocol",
    FieldType::text,
    0,
    {},
    "The protocol's id as --protocol takes it (drivetap fields: its P lines)"};
inline constexpr FieldDesc kRecordAddress{"addr",
                                          "Station address",
                                          FieldType::uint,
                                          8,
                                          {},
                                          "The station the frame is to or from (0: broadcast)"};
inline constexpr FieldDesc kRecordFunction{
    "fc",
    "Function code",
    FieldType::uint,
    8,
    {},
    "The function code or command as on the wire (Modbus: exception bit included)"};
inline constexpr FieldDesc kRecordChecksum{
    "checksum", "Checksum verdict", FieldType::text, 0, {}, "good, bad, swapped or none"};
inline constexpr FieldDesc kRecordClose{"close",
                                        "Frame close",
                                        FieldType::text,
                                        0,
                                        {},
                                        "Why the framer ended the frame: silence, content or "
                                        "end_of_input"};
// The value of `close`: "silence", "content" or "end_of_input".
constexpr std::string_view frame_close_id(FrameClose c) {
  constexpr std::string_view kIds[] = {"silence", "content", "end_of_input"};
  static_assert(std::size(kIds) == static_cast<std::size_t>(FrameClose::end_of_input) + 1);
  return enum_text(c, kIds, std::string_view{"silence"});
}
inline constexpr FieldDesc kRecordLatency{
    "latency_ms",
    "Reply latency",
    FieldType::real,
    0,
    {},
    "A paired reply: milliseconds from the end of its request to its start"};
inline constexpr FieldDesc kRecordGapBefore{"gap_before_ms",
                                            "Silence before",
                                            FieldType::real,
                                            0,
                                            {},
                                            "Milliseconds of silence before the frame"};
inline constexpr FieldDesc kRecordRequest{"request_n",
                                          "Request frame",
                                          FieldType::uint,
                                          32,
                                          {},
                                          "A paired reply: the number of its request"};
inline constexpr FieldDesc kRecordBytes{"hex", "Bytes", FieldType::bytes,
                                        0,     {},      "The frame's bytes"};
inline constexpr FieldDesc kRecordSummary{
    "summary", "Summary", FieldType::text, 0, {}, "The decode of the frame's text line"};

inline constexpr const FieldDesc* kRecordFields[] = {
    &kRecordNumber,   &kRecordTime,      &kRecordTimeEnd,  &kRecordChannel,  &kRecordDirection,
    &kRecordProtocol, &kRecordAddress,   &kRecordFunction, &kRecordChecksum, &kRecordClose,
    &kRecordLatency,  &kRecordGapBefore, &kRecordRequest,  &kRecordBytes,    &kRecordSummary,
};

inline constexpr FieldProtocol kRecordFieldProtocol{"drivetap frame record", "drivetap",
                                                    kRecordFields};

}  // namespace drivetap
