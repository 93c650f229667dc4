// sigrok session file (.sr) reader (src/sources/logic/sigrok_file.hpp), on libzip.
#include "sources/logic/sigrok_file.hpp"

#include <fmt/format.h>
#include <zip.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>

#include "formats/shared_libraries.hpp"

namespace drivetap {

struct SigrokFile::Zip {
  zip_t* archive = nullptr;
  ~Zip() {
    if (archive) zip_library().discard(archive);  // read only: nothing to write back
  }
};

SigrokFile::~SigrokFile() = default;

double parse_sample_rate(const std::string& text) {
  std::istringstream in(text);
  double value = 0;
  std::string unit;
  if (!(in >> value) || value <= 0) return 0;
  in >> unit;
  if (unit.empty() || unit == "Hz") return value;
  if (unit == "kHz") return value * 1e3;
  if (unit == "MHz") return value * 1e6;
  if (unit == "GHz") return value * 1e9;
  return 0;
}

namespace {

// sigrok writes a metadata of a few hundred bytes; a larger claim is a hostile or broken file.
constexpr zip_uint64_t kMaxMetadata = 1u << 20;

// Reads a whole zip entry of at most kMaxMetadata bytes (metadata is small; sample chunks are read
// in pieces elsewhere). *too_large when the entry claims more.
bool read_entry(zip_t* z, const std::string& name, std::string& out, bool* too_large) {
  zip_stat_t st;
  *too_large = false;
  if (zip_library().stat(z, name.c_str(), 0, &st) != 0) return false;
  if (!(st.valid & ZIP_STAT_SIZE) || st.size > kMaxMetadata) {
    *too_large = true;
    return false;
  }
  zip_file_t* f = zip_library().fopen(z, name.c_str(), 0);
  if (!f) return false;
  out.resize(static_cast<std::size_t>(st.size));
  const zip_int64_t got = zip_library().fread(f, out.data(), st.size);
  zip_library().fclose(f);
  return got == static_cast<zip_int64_t>(st.size);
}

std::string trimmed(const std::string& text) {
  const std::size_t first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

// `metadata` is INI: "[device 1]" then key=value lines ("key = value" in sigrok 0.2's files).
std::map<std::string, std::string> device_keys(const std::string& ini) {
  std::map<std::string, std::string> keys;
  std::istringstream in(ini);
  std::string line;
  bool in_device = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    line = trimmed(line);
    if (line.starts_with("[")) {
      in_device = line == "[device 1]";
      continue;
    }
    const std::size_t eq = line.find('=');
    if (in_device && eq != std::string::npos)
      keys[trimmed(line.substr(0, eq))] = trimmed(line.substr(eq + 1));
  }
  return keys;
}

// "logic-1-12" -> 12 for ordering chunks numerically.
long chunk_number(const std::string& name, const std::string& prefix) {
  if (name == prefix) return 0;
  if (!name.starts_with(prefix + "-")) return -1;
  const std::string digits = name.substr(prefix.size() + 1);
  if (digits.empty() || digits.size() > 9 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return -1;
  return std::stol(digits);
}

}  // namespace

std::unique_ptr<SigrokFile> SigrokFile::open(const std::string& path, std::string* error) {
  if (!zip_library().loaded) {
    *error = fmt::format("{}: a sigrok session file, but {}", path, zip_library().error);
    return nullptr;
  }
  std::unique_ptr<SigrokFile> file(new SigrokFile());
  file->path_ = path;
  file->zip_ = std::make_unique<Zip>();
  int code = 0;
  file->zip_->archive = zip_library().open(path.c_str(), ZIP_RDONLY, &code);
  if (!file->zip_->archive) {
    zip_error_t ze;
    zip_library().error_init_with_code(&ze, code);
    *error = fmt::format("{}: not a readable zip: {}", path, zip_library().error_strerror(&ze));
    zip_library().error_fini(&ze);
    return nullptr;
  }
  zip_t* z = file->zip_->archive;
  std::string ini;
  bool too_large = false;
  if (!read_entry(z, "metadata", ini, &too_large)) {
    *error = too_large
                 ? fmt::format(
                       "{}: 'metadata' is larger than {} bytes: not a sigrok "
                       "session file",
                       path, kMaxMetadata)
                 : fmt::format("{}: no 'metadata' in the zip: not a sigrok session file", path);
    return nullptr;
  }
  auto keys = device_keys(ini);
  const double rate = parse_sample_rate(keys["samplerate"]);
  file->sample_rate_ = static_cast<std::uint64_t>(std::llround(rate));
  if (!(rate >= 1) || rate > 1e12 || std::abs(rate - std::round(rate)) > 1e-6) {
    *error = fmt::format("{}: metadata: samplerate '{}' is not a rate", path, keys["samplerate"]);
    return nullptr;
  }
  int probes = keys.count("total probes") ? std::atoi(keys["total probes"].c_str()) : 0;
  const int analogs = keys.count("total analog") ? std::atoi(keys["total analog"].c_str()) : 0;
  std::string prefix;
  if (probes > 0) {
    if (probes > 64) {
      *error = fmt::format("{}: metadata: {} logic channels (at most 64 supported)", path, probes);
      return nullptr;
    }
    file->unit_size_ = keys.count("unitsize") ? std::atoi(keys["unitsize"].c_str()) : 1;
    if (file->unit_size_ < 1 || file->unit_size_ > 8) {
      *error =
          fmt::format("{}: metadata: unitsize {} (1 to 8 bytes a sample)", path, file->unit_size_);
      return nullptr;
    }
    // Old sessions count the device's probes, more than a sample holds: those past the sample's
    // bits were never recorded (libsigrok reads such files the same way).
    probes = std::min(probes, file->unit_size_ * 8);
    for (int i = 1; i <= probes; ++i) {
      const auto it = keys.find(fmt::format("probe{}", i));
      file->channels_.push_back(it == keys.end() ? fmt::format("{}", i - 1) : it->second);
    }
    prefix = keys.count("capturefile") ? keys["capturefile"] : "logic-1";
  } else if (analogs == 1) {
    file->analog_ = true;
    file->channels_.push_back(keys.count("analog1") ? keys["analog1"] : "A0");
    prefix = "analog-1-1";
  } else {
    *error = fmt::format(
        "{}: metadata: no logic channels and {} analog ones (one analog channel "
        "or logic channels are supported)",
        path, analogs);
    return nullptr;
  }
  std::vector<std::pair<long, std::string>> found;
  const zip_int64_t entries = zip_library().get_num_entries(z, 0);
  for (zip_int64_t i = 0; i < entries; ++i) {
    const char* name = zip_library().get_name(z, static_cast<zip_uint64_t>(i), 0);
    if (!name) continue;
    const long n = chunk_number(name, prefix);
    if (n >= 0) found.emplace_back(n, name);
  }
  std::sort(found.begin(), found.end());
  for (auto& [n, name] : found) file->chunks_.push_back(std::move(name));
  if (file->chunks_.empty()) {
    *error = fmt::format("{}: no sample data ('{}-1' ...) in the zip", path, prefix);
    return nullptr;
  }
  return file;
}

struct SigrokFile::Entry {
  zip_file_t* file = nullptr;
  std::string name;
  ~Entry() {
    if (file) zip_library().fclose(file);
  }
};

namespace {
constexpr std::size_t kReadBytes = 1 << 20;  // raw bytes per block
}  // namespace

bool SigrokFile::open_next_entry(std::string* error) {
  entry_.reset();
  if (next_chunk_ >= chunks_.size()) return true;
  auto entry = std::make_unique<Entry>();
  entry->name = chunks_[next_chunk_++];
  entry->file = zip_library().fopen(zip_->archive, entry->name.c_str(), 0);
  if (!entry->file) {
    *error = fmt::format("{}: {}: cannot open: {}", path_, entry->name,
                         zip_library().strerror(zip_->archive));
    return false;
  }
  entry_ = std::move(entry);
  entry_offset_ = 0;
  return true;
}

// Back to the first sample chunk.
bool SigrokFile::rewind(std::string* error) {
  next_chunk_ = 0;
  filled_ = 0;
  used_ = 0;
  pass_bytes_ = 0;
  raw_.resize(kReadBytes + 8);  // room for the part of a sample a read leaves over
  return open_next_entry(error);
}

// Reads on through the sample chunks: *samples whole samples at the start of raw_ (0 at the end of
// the capture), a sample split between two reads (or two chunks' reads) carried to the next piece.
// False with *error when the zip is damaged.
bool SigrokFile::read_piece(std::size_t* samples, std::string* error) {
  const std::size_t unit = analog_ ? sizeof(float) : static_cast<std::size_t>(unit_size_);
  filled_ -= used_;
  std::memmove(raw_.data(), raw_.data() + used_, filled_);
  used_ = 0;
  *samples = 0;
  while (entry_) {
    const zip_int64_t got = zip_library().fread(entry_->file, raw_.data() + filled_, kReadBytes);
    if (got < 0) {
      *error = fmt::format("{}: {}: offset {}: damaged: {}", path_, entry_->name, entry_offset_,
                           zip_library().file_strerror(entry_->file));
      entry_.reset();
      return false;
    }
    if (got == 0) {
      if (filled_ != 0) {
        *error = fmt::format("{}: {}: ends inside a sample ({} stray bytes)", path_, entry_->name,
                             filled_);
        entry_.reset();
        return false;
      }
      if (!open_next_entry(error)) return false;
      continue;
    }
    entry_offset_ += static_cast<std::uint64_t>(got);
    pass_bytes_ += static_cast<std::uint64_t>(got);
    if (max_sample_bytes_ > 0 && pass_bytes_ > max_sample_bytes_) {
      *error = fmt::format(
          "{}: {}: offset {}: the samples decompress to more than {} bytes, the limit "
          "(--logic-max; a zip bomb?): read up to there",
          path_, entry_->name, entry_offset_ - static_cast<std::uint64_t>(got), max_sample_bytes_);
      entry_.reset();
      return false;
    }
    filled_ += static_cast<std::size_t>(got);
    *samples = filled_ / unit;
    if (*samples == 0) continue;
    used_ = *samples * unit;
    return true;
  }
  return true;
}

// An oscilloscope trace has no logic levels: a first pass finds its range.
bool SigrokFile::find_analog_range(std::string* error) {
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  if (!rewind(error)) return false;
  for (std::size_t samples = 0;;) {
    if (!read_piece(&samples, error)) return false;
    if (samples == 0) break;
    for (std::size_t i = 0; i < samples; ++i) {
      float v;
      std::memcpy(&v, raw_.data() + i * sizeof(float), sizeof v);
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
    }
  }
  if (lo > hi) lo = hi = 0;
  // A Schmitt trigger 10 % of the range either side of the middle: noise on a slow edge crosses
  // a single threshold several times and would read as glitches.
  const float middle = lo + (hi - lo) / 2, margin = (hi - lo) / 10;
  analog_low_ = middle - margin;
  analog_high_ = middle + margin;
  analog_range_known_ = true;
  return true;
}

bool SigrokFile::select(const std::vector<std::size_t>& channels, std::string* error) {
  for (std::size_t c : channels)
    if (c >= channels_.size()) {
      *error = fmt::format("{}: no channel {} (it has {})", path_, c, channels_.size());
      return false;
    }
  if (analog_ && !analog_range_known_ && !find_analog_range(error)) return false;
  selected_ = channels;
  sample_ = 0;
  have_level_ = false;
  last_word_ = 0;
  run_start_.assign(channels.size(), 0);
  level_.assign(channels.size(), true);
  return rewind(error);
}

// Logic samples -> runs. Most of a capture is idle line, and even a busy one changes a selected
// bit only every few samples: eight bytes are compared at once with the previous sample repeated
// (one-, two-, four- and eight-byte samples), and the first changed sample among them is found by
// counting trailing zero bits, so that only a sample where a selected bit changes costs more.
void SigrokFile::scan_logic(const std::uint8_t* bytes, std::size_t samples, RunBlock& block) {
  const auto unit = static_cast<std::size_t>(unit_size_);
  std::uint64_t mask = 0;
  for (std::size_t c : selected_) mask |= std::uint64_t{1} << c;
  auto word_at = [&](std::size_t i) {
    std::uint64_t w = 0;
    for (std::size_t b = 0; b < unit; ++b)
      w |= static_cast<std::uint64_t>(bytes[i * unit + b]) << (8 * b);
    return w & mask;
  };
  // Sample i differs from the previous one in the selected bits: every changed channel's run
  // ends here.
  auto change_at = [&](std::size_t i, std::uint64_t w) {
    const std::uint64_t changed = w ^ last_word_;
    const std::uint64_t at = sample_ + i;
    for (std::size_t k = 0; k < selected_.size(); ++k) {
      if (!((changed >> selected_[k]) & 1)) continue;
      if (at > run_start_[k]) block.runs[k].push_back({level_[k], at - run_start_[k]});
      level_[k] = !level_[k];
      run_start_[k] = at;
    }
    last_word_ = w;
  };
  std::size_t i = 0;
  if (!have_level_ && samples > 0) {
    last_word_ = word_at(0);
    for (std::size_t k = 0; k < selected_.size(); ++k) level_[k] = (last_word_ >> selected_[k]) & 1;
    have_level_ = true;
  }
  // Eight bytes hold 8 / unit whole samples, sample j of them in bits [8 unit j, 8 unit (j + 1)).
  if (std::endian::native == std::endian::little && std::has_single_bit(unit) && unit <= 8) {
    const int sample_bits_log2 = 3 + std::countr_zero(unit);  // 8 unit = 1 << this
    const std::size_t per_word = 8 / unit;
    // Multiplying a sample by this repeats it in every sample of the eight bytes.
    const std::uint64_t spread = unit == 8   ? 1
                                 : unit == 4 ? 0x0000000100000001ULL
                                 : unit == 2 ? 0x0001000100010001ULL
                                             : 0x0101010101010101ULL;
    const std::uint64_t mask8 = mask * spread;
    std::uint64_t same = last_word_ * spread;
    while (i + per_word <= samples) {
      std::uint64_t eight;
      std::memcpy(&eight, bytes + i * unit, 8);
      const std::uint64_t diff = (eight ^ same) & mask8;
      if (diff == 0) {
        i += per_word;
        continue;
      }
      // The first sample with a changed bit, and where it begins in the eight bytes.
      const int j = std::countr_zero(diff) >> sample_bits_log2;
      i += static_cast<std::size_t>(j);
      change_at(i, (eight >> (j << sample_bits_log2)) & mask);
      same = last_word_ * spread;
      ++i;
    }
  }
  for (; i < samples; ++i) {
    const std::uint64_t w = word_at(i);
    if (w != last_word_) change_at(i, w);
  }
}

void SigrokFile::scan_analog(const std::uint8_t* bytes, std::size_t samples, RunBlock& block) {
  for (std::size_t i = 0; i < samples; ++i) {
    float v;
    std::memcpy(&v, bytes + i * sizeof(float), sizeof v);
    if (!std::isfinite(v)) continue;  // keeps the level: a missing point is no edge
    if (!have_level_) {
      level_[0] = v > (analog_low_ + analog_high_) / 2;
      have_level_ = true;
      continue;
    }
    const bool level = level_[0] ? !(v < analog_low_) : v > analog_high_;
    if (level == level_[0]) continue;
    const std::uint64_t at = sample_ + i;
    if (at > run_start_[0]) block.runs[0].push_back({level_[0], at - run_start_[0]});
    level_[0] = level;
    run_start_[0] = at;
  }
}

bool SigrokFile::next_block(RunBlock& block, std::string* error) {
  block.begin = sample_;
  // Cleared, not reallocated: a reader of many blocks keeps the capacity the busiest one needed.
  block.runs.resize(selected_.size());
  for (auto& runs : block.runs) runs.clear();
  std::size_t samples = 0;
  if (!read_piece(&samples, error) || samples == 0) return false;
  if (analog_)
    scan_analog(raw_.data(), samples, block);
  else
    scan_logic(raw_.data(), samples, block);
  sample_ += samples;
  // Close every channel's run at the block end; the next block continues it.
  for (std::size_t k = 0; k < selected_.size(); ++k) {
    if (sample_ > run_start_[k]) block.runs[k].push_back({level_[k], sample_ - run_start_[k]});
    run_start_[k] = sample_;
  }
  block.end = sample_;
  return true;
}

}  // namespace drivetap
