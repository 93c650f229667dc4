// Unit tests: the sigrok reader's logic scan (src/sources/logic/sigrok_file.cpp, scan_logic) against a
// sample-by-sample reference, on sessions written here with libzip: every unit size 1..8 (eight
// bytes compared at once for 1, 2, 4 and 8; one sample at a time for the others), changes sparse
// and dense, at the first and last sample of a read and of a chunk, selections in any order.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zip.h>

#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "sources/logic/sigrok_file.hpp"

using namespace drivetap;

namespace {

// A session of `unit`-byte samples, cut into chunks of `chunk_samples`.
// A session file's path in the temporary directory, with the process id: runs of the suite at
// the same time use files of their own.
std::string session_path(const std::string& stem) {
  return (std::filesystem::temp_directory_path() /
          (stem + "_" + std::to_string(::getpid()) + ".sr"))
      .string();
}

std::string write_session(const std::string& name, int unit,
                          const std::vector<std::uint64_t>& words, std::size_t chunk_samples) {
  const std::string path = session_path("drivetap_SigrokScan_" + name);
  std::vector<std::uint8_t> raw;
  for (std::uint64_t w : words)
    for (int b = 0; b < unit; ++b) raw.push_back(static_cast<std::uint8_t>(w >> (8 * b)));
  int code = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
  EXPECT_NE(z, nullptr) << path;
  if (!z) return path;
  std::string metadata = fmt::format(
      "[device 1]\ncapturefile=logic-1\ntotal probes={}\nsamplerate=1 MHz\nunitsize={}\n", 8 * unit,
      unit);
  auto add = [&](const std::string& entry, const void* data, std::size_t size) {
    zip_source_t* src = zip_source_buffer(z, data, size, 0);
    ASSERT_NE(src, nullptr);
    ASSERT_GE(zip_file_add(z, entry.c_str(), src, ZIP_FL_OVERWRITE), 0) << zip_strerror(z);
  };
  add("metadata", metadata.data(), metadata.size());
  const std::size_t chunk_bytes = chunk_samples * static_cast<std::size_t>(unit);
  for (std::size_t at = 0, n = 1; at < raw.size(); at += chunk_bytes, ++n)
    add(fmt::format("logic-1-{}", n), raw.data() + at, std::min(chunk_bytes, raw.size() - at));
  EXPECT_EQ(zip_close(z), 0) << zip_strerror(z);
  return path;
}

// Runs of one channel, sample by sample.
std::vector<phy::LevelRun> reference_runs(const std::vector<std::uint64_t>& words,
                                          std::size_t channel) {
  std::vector<phy::LevelRun> runs;
  for (std::uint64_t w : words) {
    const bool level = (w >> channel) & 1;
    if (!runs.empty() && runs.back().level == level)
      ++runs.back().length;
    else
      runs.push_back({level, 1});
  }
  return runs;
}

// What the reader hands out, block by block, with runs continued across blocks merged.
std::vector<std::vector<phy::LevelRun>> read_runs(const std::string& path,
                                                  const std::vector<std::size_t>& channels) {
  std::string error;
  auto file = SigrokFile::open(path, &error);
  EXPECT_TRUE(file) << error;
  std::vector<std::vector<phy::LevelRun>> merged(channels.size());
  if (!file) return merged;
  EXPECT_TRUE(file->select(channels, &error)) << error;
  RunBlock block;  // one block object for the whole read, as a consumer keeps it
  std::uint64_t next = 0;
  while (file->next_block(block, &error)) {
    EXPECT_EQ(block.begin, next);
    next = block.end;
    EXPECT_EQ(block.runs.size(), channels.size());
    for (std::size_t k = 0; k < block.runs.size(); ++k) {
      std::uint64_t covered = 0;
      for (const phy::LevelRun& run : block.runs[k]) {
        EXPECT_GT(run.length, 0u);
        covered += run.length;
        if (!merged[k].empty() && merged[k].back().level == run.level)
          merged[k].back().length += run.length;
        else
          merged[k].push_back(run);
      }
      EXPECT_EQ(covered, block.end - block.begin);
    }
  }
  EXPECT_TRUE(error.empty()) << error;
  return merged;
}

// Random samples: each sample keeps the previous one, or with probability 1/change_every flips
// a few random bits.
std::vector<std::uint64_t> random_words(int unit, std::size_t samples, unsigned change_every,
                                        std::uint32_t seed) {
  std::mt19937_64 rng(seed);
  const std::uint64_t all = unit == 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * unit)) - 1;
  std::vector<std::uint64_t> words(samples);
  std::uint64_t w = rng() & all;
  for (std::uint64_t& x : words) {
    if (rng() % change_every == 0)
      w ^= (std::uint64_t{1} << (rng() % (8 * unit))) | (rng() & all & rng());
    x = w;
  }
  return words;
}

void check_unit(int unit, unsigned change_every, std::uint32_t seed) {
  SCOPED_TRACE(fmt::format("unit {} change 1/{} seed {}", unit, change_every, seed));
  // Over 1 MiB of samples so that reads end inside chunks; chunks of an odd number of samples.
  const std::size_t samples = (3u << 20) / static_cast<std::size_t>(unit) + 13;
  const auto words = random_words(unit, samples, change_every, seed);
  const std::string path =
      write_session(fmt::format("u{}_{}_{}", unit, change_every, seed), unit, words, 300'007);
  std::mt19937 rng(seed);
  std::vector<std::size_t> channels;
  for (int n = 0; n < 3; ++n) channels.push_back(rng() % (8 * static_cast<unsigned>(unit)));
  channels.push_back(8 * static_cast<std::size_t>(unit) - 1);  // the top bit of the sample
  const auto got = read_runs(path, channels);
  for (std::size_t k = 0; k < channels.size(); ++k)
    EXPECT_EQ(got[k], reference_runs(words, channels[k])) << "channel " << channels[k];
  std::filesystem::remove(path);
}

}  // namespace

TEST(SigrokScan, EveryUnitSizeSparseChanges) {
  for (int unit = 1; unit <= 8; ++unit) check_unit(unit, 97, 1);
}

TEST(SigrokScan, EveryUnitSizeDenseChanges) {
  for (int unit = 1; unit <= 8; ++unit) check_unit(unit, 2, 2);
}

TEST(SigrokScan, EveryUnitSizeChangeEverySample) {
  for (int unit : {1, 2, 4, 8}) check_unit(unit, 1, 3);
}

// A change on the very first and last sample of the capture and at every multiple of eight bytes.
TEST(SigrokScan, ChangesAtWordAndCaptureEdges) {
  for (int unit : {1, 2, 4, 8}) {
    SCOPED_TRACE(unit);
    const std::size_t samples = 4096 + 3;
    std::vector<std::uint64_t> words(samples, 0);
    const std::size_t per_word = 8 / static_cast<std::size_t>(unit);
    bool level = false;
    for (std::size_t i = 0; i < samples; ++i) {
      if (i == 1 || i % per_word == 0 || i % per_word == per_word - 1 || i == samples - 1)
        level = !level;
      words[i] = level ? std::uint64_t{1} << (8 * unit - 1) : 0;
    }
    const std::string path = write_session(fmt::format("edges_u{}", unit), unit, words, 1000);
    const std::size_t top = 8 * static_cast<std::size_t>(unit) - 1;
    const auto got = read_runs(path, {top, 0});
    EXPECT_EQ(got[0], reference_runs(words, top));
    EXPECT_EQ(got[1], reference_runs(words, 0));
    std::filesystem::remove(path);
  }
}

TEST(SigrokFile, OversizedMetadataIsRefused) {
  // metadata is read whole: a claim past 1 MiB is refused before any allocation of its size.
  const std::string path = session_path("drivetap_SigrokFile_big_metadata");
  int code = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
  ASSERT_NE(z, nullptr);
  std::string metadata = "[device 1]\ncapturefile=logic-1\ntotal probes=1\nsamplerate=1 MHz\n";
  metadata.resize((1u << 20) + 1, ';');
  zip_source_t* src = zip_source_buffer(z, metadata.data(), metadata.size(), 0);
  ASSERT_NE(src, nullptr);
  ASSERT_GE(zip_file_add(z, "metadata", src, ZIP_FL_OVERWRITE), 0);
  const std::uint8_t sample = 1;
  src = zip_source_buffer(z, &sample, 1, 0);
  ASSERT_GE(zip_file_add(z, "logic-1-1", src, ZIP_FL_OVERWRITE), 0);
  ASSERT_EQ(zip_close(z), 0);
  std::string error;
  EXPECT_EQ(SigrokFile::open(path, &error), nullptr);
  EXPECT_NE(error.find(path + ": 'metadata' is larger than 1048576 bytes"), std::string::npos)
      << error;
  std::filesystem::remove(path);
}
