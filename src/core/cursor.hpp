// Cursor: the only way dissectors read packet bytes — a bounds-checked reader over a span.
//
// Every read either succeeds and advances, or fails and leaves the cursor where it was; a
// dissector's loops are bounded by remaining(), which every successful read strictly lowers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>

namespace drivetap {

class Cursor {
 public:
  explicit Cursor(std::span<const std::uint8_t> data) : data_(data) {}

  [[nodiscard]] std::size_t offset() const { return pos_; }
  [[nodiscard]] std::size_t remaining() const { return data_.size() - pos_; }
  [[nodiscard]] bool empty() const { return pos_ >= data_.size(); }
  [[nodiscard]] std::size_t size() const { return data_.size(); }

  std::optional<std::uint8_t> u8() {
    if (remaining() < 1) return std::nullopt;
    return data_[pos_++];
  }
  std::optional<std::uint16_t> be16() {
    if (remaining() < 2) return std::nullopt;
    const auto v = static_cast<std::uint16_t>((data_[pos_] << 8) | data_[pos_ + 1]);
    pos_ += 2;
    return v;
  }
  std::optional<std::uint16_t> le16() {
    if (remaining() < 2) return std::nullopt;
    const auto v = static_cast<std::uint16_t>(data_[pos_] | (data_[pos_ + 1] << 8));
    pos_ += 2;
    return v;
  }
  std::optional<std::span<const std::uint8_t>> take(std::size_t n) {
    if (remaining() < n) return std::nullopt;
    auto s = data_.subspan(pos_, n);
    pos_ += n;
    return s;
  }
  std::span<const std::uint8_t> rest() {
    auto s = data_.subspan(pos_);
    pos_ = data_.size();
    return s;
  }
  // Value at offset `ahead` from the current position without consuming it.
  [[nodiscard]] std::optional<std::uint8_t> peek(std::size_t ahead = 0) const {
    if (remaining() <= ahead) return std::nullopt;
    return data_[pos_ + ahead];
  }

 private:
  std::span<const std::uint8_t> data_;
  std::size_t pos_ = 0;
};

}  // namespace drivetap
