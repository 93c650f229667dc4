// FrameQueue: the pipeline's reorder stage — frames closed but not handed on yet, because another
// channel may still close a frame that started earlier (docs/reference.md "Order of the output").
#pragma once

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

#include "core/frame.hpp"
#include "core/protocol.hpp"

namespace drivetap {

// Frames in order of their first byte (frames starting together: in channel order), each with
// the decoder of the framer that cut it (its channel may be detecting afresh by the time it goes
// on). A frame comes in and goes out by swapping with a slot, so that the slots keep their storage
// for the frames after: the queue allocates nothing in the steady state.
class FrameQueue {
 public:
  struct Slot {
    Frame frame;
    const ProtocolDecoder* decoder = nullptr;
  };
  [[nodiscard]] bool empty() const { return head_ == tail_; }
  [[nodiscard]] std::size_t size() const { return tail_ - head_; }
  [[nodiscard]] Slot& front() { return slots_[head_]; }
  [[nodiscard]] const Slot& front() const { return slots_[head_]; }

  // Takes `f`'s content; `f` gets a spare slot's storage in exchange.
  void push(Frame& f, const ProtocolDecoder* decoder) {
    if (tail_ == slots_.size()) {
      // The slots before head_ are free: moved to the end once they are half of all, else the
      // queue grows (so that each frame is moved at most a few times on average).
      if (head_ > 0 && head_ * 2 >= slots_.size()) {
        std::rotate(slots_.begin(), slots_.begin() + static_cast<std::ptrdiff_t>(head_),
                    slots_.end());
        tail_ -= head_;
        head_ = 0;
      } else {
        slots_.emplace_back();
      }
    }
    std::swap(slots_[tail_].frame, f);
    slots_[tail_].decoder = decoder;
    // Frames come nearly in order: the new one moves back past the few that start later.
    auto after = [](const Frame& a, const Frame& b) {
      return a.start() != b.start() ? a.start() > b.start() : a.channel > b.channel;
    };
    for (std::size_t i = tail_++; i > head_ && after(slots_[i - 1].frame, slots_[i].frame); --i)
      std::swap(slots_[i - 1], slots_[i]);
  }
  // Forgets the front frame (handed on); its slot keeps the storage, up to kKeptStorageBytes.
  void pop() {
    if (slots_[head_].frame.storage_bytes() > kKeptStorageBytes) slots_[head_].frame = Frame{};
    if (++head_ == tail_) head_ = tail_ = 0;
  }

 private:
  std::vector<Slot> slots_;
  std::size_t head_ = 0;  // the frames waiting: slots_[head_, tail_)
  std::size_t tail_ = 0;
};

}  // namespace drivetap
