// An output line built by appends that stay inline: the JSON sink's per-frame line.
// std::string's append is a call into libstdc++ (and a memcpy call) for every piece; a line of
// some forty pieces per frame made those calls a large part of writing JSON. The helpers of
// core/format.hpp and the JSON escaping take either type.
#pragma once

#include <cstddef>
#include <cstring>
#include <memory>
#include <string_view>
#include <utility>

namespace drivetap {

class LineBuffer {
 public:
  using value_type = char;  // for std::back_inserter (fmt on the rare paths)

  LineBuffer() = default;
  // One owner per line: not copied (a sink keeps its own); moved with its owner (a drive reading
  // builds its text in one), the moved-from buffer left empty.
  LineBuffer(const LineBuffer&) = delete;
  LineBuffer& operator=(const LineBuffer&) = delete;
  LineBuffer(LineBuffer&& other) noexcept { swap(other); }
  LineBuffer& operator=(LineBuffer&& other) noexcept {
    LineBuffer taken(std::move(other));
    swap(taken);
    return *this;
  }

  void clear() { size_ = 0; }
  // Exchanges contents with `other` (no copy): a buffer handed from one owner to the next.
  void swap(LineBuffer& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(capacity_, other.capacity_);
  }
  [[nodiscard]] std::size_t size() const { return size_; }
  [[nodiscard]] bool empty() const { return size_ == 0; }
  [[nodiscard]] const char* data() const { return data_.get(); }
  [[nodiscard]] std::string_view view() const { return {data_.get(), size_}; }
  [[nodiscard]] const char* begin() const { return data_.get(); }
  [[nodiscard]] const char* end() const { return data_.get() + size_; }

  // `s` may point into this buffer (its view()): the old storage outlives the copy.
  // (GCC's array-bounds check looks into the branches for other lengths where a literal's
  // length is known, and warns about copies that never run.)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Warray-bounds"
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wstringop-overread"
#endif
  [[gnu::always_inline]] void append(const char* s, std::size_t n) {
    // An empty piece copies nothing; memcpy with a still unallocated buffer's null pointer would be
    // undefined even for 0 bytes.
    if (n == 0) return;
    if (capacity_ - size_ < n) return append_growing(s, n);
    char* at = data_.get() + size_;
    size_ += n;
    // A literal's length is known here: the compiler copies it with a few moves.
    if (__builtin_constant_p(n)) {
      std::memcpy(at, s, n);
      return;
    }
    // Most other pieces are short: two fixed-size copies that overlap, not a call to memcpy.
    // They read and write only inside [s, s + n) and [at, at + n).
    if (n >= 8 && n <= 16) {
      std::memcpy(at, s, 8);
      std::memcpy(at + n - 8, s + n - 8, 8);
    } else if (n >= 4 && n < 8) {
      std::memcpy(at, s, 4);
      std::memcpy(at + n - 4, s + n - 4, 4);
    } else if (n < 4) {
      for (std::size_t i = 0; i < n; ++i) at[i] = s[i];
    } else {
      std::memcpy(at, s, n);
    }
  }
#pragma GCC diagnostic pop
  [[gnu::always_inline]] void append(std::string_view s) {
    append(s.data(), s.size());
  }
  void append(std::size_t n, char c) {
    if (n != 0) std::memset(extend(n), c, n);
  }
  // Inlined: a sink appends a separator or a quote between most pieces.
  [[gnu::always_inline]] void push_back(char c) {
    if (capacity_ == size_) grow(1);
    data_[size_++] = c;
  }
  [[gnu::always_inline]] LineBuffer& operator+=(std::string_view s) {
    append(s);
    return *this;
  }
  // Inlined, so that the length of a literal is known where it is appended.
  [[gnu::always_inline]] LineBuffer& operator+=(const char* s) {
    append(std::string_view(s));
    return *this;
  }
  [[gnu::always_inline]] LineBuffer& operator+=(char c) {
    push_back(c);
    return *this;
  }
  // As std::string::resize: drops the characters from `n` on, or adds `n - size()` NULs.
  void resize(std::size_t n) {
    if (n <= size_)
      size_ = n;
    else
      append(n - size_, '\0');
  }
  // `n` more characters at the end, for the caller to fill; they count in size() at once.
  char* extend(std::size_t n) {
    if (capacity_ - size_ < n) grow(n);
    char* at = data_.get() + size_;
    size_ += n;
    return at;
  }

 private:
  // Room for `more` characters past size(): at least doubles, so appends stay amortised O(1).
  // Returns the old storage, for a caller still reading from it.
  std::unique_ptr<char[]> grow(std::size_t more) {
    std::size_t capacity = capacity_ < 256 ? 256 : capacity_;
    while (capacity - size_ < more) capacity *= 2;
    std::unique_ptr<char[]> bigger(new char[capacity]);
    if (size_ != 0) std::memcpy(bigger.get(), data_.get(), size_);
    std::swap(data_, bigger);
    capacity_ = capacity;
    return bigger;
  }
  [[gnu::noinline]] void append_growing(const char* s, std::size_t n) {
    if (n == 0) return;
    const std::unique_ptr<char[]> old = grow(n);  // freed after the copy: `s` may be in it
    std::memcpy(data_.get() + size_, s, n);
    size_ += n;
  }

  std::unique_ptr<char[]> data_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

}  // namespace drivetap
