// Reading a telegram's drive records (core/drive_records.hpp) through its protocol's decoder
// (ProtocolDecoder::read_drive_records()), for the drive level: the one place it asks for them.
#pragma once

#include <span>

#include "core/drive_records.hpp"
#include "core/protocol.hpp"

namespace drivetap {

class DriveRecordReader {
 public:
  // Reads `telegram` (a reply with its request's bytes, empty when unknown) into records(),
  // whose storage is kept from one telegram to the next; no records for a telegram of no known
  // protocol.
  const DriveRecords& read(const TelegramHead& telegram, std::span<const std::uint8_t> request) {
    // decoder_for() of the last protocol read: a bus's telegrams are mostly of one, and a lookup
    // for each telegram cost the hot path.
    if (telegram.protocol != protocol_) {
      protocol_ = telegram.protocol;
      decoder_ = decoder_for(protocol_);
    }
    if (decoder_)
      decoder_->read_drive_records(telegram, request, records_);
    else
      records_.clear();
    records_.request_unseen = telegram.direction == Direction::response && request.empty();
    return records_;
  }
  [[nodiscard]] const DriveRecords& records() const { return records_; }

 private:
  DriveRecords records_;
  Protocol protocol_ = Protocol::unknown;
  const ProtocolDecoder* decoder_ = nullptr;  // decoder_for(protocol_)
};

// One telegram's drive records, read when first asked for and kept for the rest of the telegram's
// way through the drive level: the binder and the annotation share one reading. A reply is read
// with its request (the binder weighs a reply only so).
class TelegramDriveRecords {
 public:
  // `reader` lends its storage; `telegram` and `request` must outlive this.
  TelegramDriveRecords(DriveRecordReader& reader, const TelegramHead& telegram,
                       std::span<const std::uint8_t> request)
      : reader_(reader), telegram_(telegram), request_(request) {}
  [[nodiscard]] const TelegramHead& telegram() const { return telegram_; }
  // A reply read with the request it answers.
  [[nodiscard]] bool answers_request() const { return !request_.empty(); }
  const DriveRecords& get() {
    if (!read_) {
      reader_.read(telegram_, request_);
      read_ = true;
    }
    return reader_.records();
  }

 private:
  DriveRecordReader& reader_;
  const TelegramHead& telegram_;
  std::span<const std::uint8_t> request_;
  bool read_ = false;
};

}  // namespace drivetap
