// Units for FrameBatch (src/core/frame.hpp): the framers' output, keeping frames' storage.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/frame.hpp"

namespace drivetap {
namespace {

// A frame of `count` bytes (value `tag`) with every member away from its default.
void fill(Frame& f, std::uint8_t tag, std::size_t count) {
  f.kind = FrameKind::noise;
  f.channel = 3;
  for (std::size_t i = 0; i < count; ++i)
    f.events.push_back({static_cast<TimeNs>(1000 * (i + 1)), tag, 0x04, 3, 7});
  f.gap_before = 12345;
  f.close = FrameClose::end_of_input;
  f.checksum_kind = FrameChecksum::crc16_modbus;
  f.checksum = 0xBEEF;
  f.max_intra_gap = 777;
  f.max_intra_gap_at = 5;
  f.number = 99;
}

void expect_like_a_new_frame(const Frame& f) {
  const Frame fresh;
  EXPECT_EQ(f.kind, fresh.kind);
  EXPECT_EQ(f.channel, fresh.channel);
  EXPECT_TRUE(f.events.empty());
  EXPECT_FALSE(f.events.any_flags());
  EXPECT_EQ(f.gap_before, fresh.gap_before);
  EXPECT_EQ(f.close, fresh.close);
  EXPECT_EQ(f.checksum_kind, fresh.checksum_kind);
  EXPECT_EQ(f.checksum, fresh.checksum);
  EXPECT_EQ(f.max_intra_gap, fresh.max_intra_gap);
  EXPECT_EQ(f.max_intra_gap_at, fresh.max_intra_gap_at);
  EXPECT_EQ(f.number, fresh.number);
}

TEST(FrameBatch, AddBuildsANewFrameInTheStorageOfTheOldOne) {
  FrameBatch batch;
  fill(batch.add(), 0xAA, 100);
  const std::size_t capacity = batch[0].events.capacity();
  ASSERT_GE(capacity, 100u);
  batch.clear();
  EXPECT_TRUE(batch.empty());
  Frame& f = batch.add();
  EXPECT_EQ(batch.size(), 1u);
  expect_like_a_new_frame(f);
  EXPECT_EQ(f.events.capacity(), capacity);
  // The storage takes the new frame's events as a new one would.
  f.events.push_back({5, 0x01, 0, 0, 0});
  EXPECT_EQ(f.events, ByteEvents({{5, 0x01, 0, 0, 0}}));
}

TEST(FrameBatch, ReadsLikeAVectorOfItsFrames) {
  FrameBatch batch;
  for (std::uint8_t k = 1; k <= 5; ++k) fill(batch.add(), k, k);
  batch.clear();
  for (std::uint8_t k = 1; k <= 3; ++k) fill(batch.add(), static_cast<std::uint8_t>(10 + k), 2);
  // Only the three frames since clear() are the batch, in order.
  ASSERT_EQ(batch.size(), 3u);
  EXPECT_EQ(std::distance(batch.begin(), batch.end()), 3);
  std::vector<std::uint8_t> firsts;
  for (const Frame& f : batch) firsts.push_back(f.events.byte(0));
  EXPECT_EQ(firsts, (std::vector<std::uint8_t>{11, 12, 13}));
  EXPECT_EQ(batch.back().events.byte(0), 13);
  EXPECT_EQ(batch.at(2).events.byte(0), 13);
  EXPECT_THROW((void)batch.at(3), std::out_of_range);
  const std::vector<Frame> taken = batch.take();
  ASSERT_EQ(taken.size(), 3u);
  EXPECT_EQ(taken[2].events.byte(0), 13);
  EXPECT_TRUE(batch.empty());
}

TEST(FrameBatch, AddWithKindChannelAndCloseSetsThoseAndResetsTheRest) {
  FrameBatch batch;
  fill(batch.add(), 0x11, 40);
  batch.clear();
  Frame& f = batch.add(FrameKind::noise, 5, FrameClose::content);
  ASSERT_EQ(batch.size(), 1u);
  EXPECT_EQ(f.kind, FrameKind::noise);
  EXPECT_EQ(f.channel, 5);
  EXPECT_EQ(f.close, FrameClose::content);
  EXPECT_GE(f.events.capacity(), 40u);
  // Every other member as in a new frame.
  f.kind = Frame().kind;
  f.channel = Frame().channel;
  f.close = Frame().close;
  expect_like_a_new_frame(f);
}

TEST(FrameBatch, SwapExchangesFramesAndStorage) {
  FrameBatch a, b;
  fill(a.add(), 0x01, 1);
  fill(a.add(), 0x02, 1);
  fill(b.add(), 0x03, 1);
  a.swap(b);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(a[0].events.byte(0), 0x03);
  EXPECT_EQ(b[1].events.byte(0), 0x02);
}

TEST(FrameBatch, AMovedFromBatchIsEmpty) {
  FrameBatch a;
  fill(a.add(), 0x01, 4);
  fill(a.add(), 0x02, 4);
  FrameBatch b(std::move(a));
  EXPECT_EQ(b.size(), 2u);
  EXPECT_TRUE(a.empty());  // NOLINT(bugprone-use-after-move): a moved-from batch is empty
  EXPECT_EQ(a.begin(), a.end());
  fill(a.add(), 0x03, 1);
  EXPECT_EQ(a.size(), 1u);
  FrameBatch c;
  c = std::move(b);
  EXPECT_EQ(c.size(), 2u);
  EXPECT_TRUE(b.empty());  // NOLINT(bugprone-use-after-move)
  EXPECT_EQ(c[1].events.byte(0), 0x02);
}

TEST(FrameBatch, ClearKeepsTheStorageOfAtMostKeptFrames) {
  const std::size_t many = FrameBatch::kKeptFrames + 10;
  FrameBatch batch;
  for (std::size_t k = 0; k < many; ++k) fill(batch.add(), 0x33, 8);
  batch.clear();
  for (std::size_t k = 0; k < many; ++k) (void)batch.add();
  for (std::size_t k = 0; k < many; ++k) {
    SCOPED_TRACE(k);
    if (k < FrameBatch::kKeptFrames)
      EXPECT_GE(batch[k].events.capacity(), 8u);
    else
      EXPECT_EQ(batch[k].events.capacity(), 0u);
  }
}

// A noisy bus as a logic analyser sees it: every byte stamped on its own, each gap longer than
// the one before, so that each byte needs a stretch of its own.
void fill_unevenly_stamped(Frame& f, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i)
    f.events.push_back({static_cast<TimeNs>(1000 * i + i * (i + 1) / 2), 0x55, 0, 0, 0});
}

TEST(FrameBatch, AFrameStampedByteByByteHoldsStorageForEachByte) {
  Frame f;
  fill_unevenly_stamped(f, 4096);
  EXPECT_GE(f.storage_bytes(), 4096u * (1 + sizeof(ByteEvents::Stretch) / 2));  // a stretch a pair
  Frame even;
  fill(even, 0x11, 4096);  // evenly spaced: one stretch
  EXPECT_LT(even.storage_bytes(), 3 * 4096u);
}

TEST(FrameBatch, ClearFreesTheStorageOfAFrameHoldingMoreThanKept) {
  FrameBatch batch;
  fill(batch.add(), 0x22, 8);
  fill_unevenly_stamped(batch.add(), 4096);  // some 70 KiB
  fill(batch.add(), 0x22, 8);
  ASSERT_GT(batch[1].storage_bytes(), kKeptStorageBytes);
  batch.clear();
  for (int k = 0; k < 3; ++k) (void)batch.add();
  EXPECT_GE(batch[0].events.capacity(), 8u);
  EXPECT_EQ(batch[1].storage_bytes(), 0u);
  EXPECT_GE(batch[2].events.capacity(), 8u);
  // A frame just under the bound keeps its storage.
  batch.clear();
  fill_unevenly_stamped(batch.add(), 64);
  ASSERT_LE(batch[0].storage_bytes(), kKeptStorageBytes);
  const std::size_t kept = batch[0].storage_bytes();
  batch.clear();
  (void)batch.add();
  EXPECT_EQ(batch[0].storage_bytes(), kept);
}

}  // namespace
}  // namespace drivetap
