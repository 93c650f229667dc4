// sigrok session file (.sr) reader (src/sources/sigrok_file.hpp), on libzip.
#include "sources/sigrok_file.hpp"

#include <fmt/format.h>
#include <zip.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>

namespace drivetap {

struct SigrokFile::Zip {
  zip_t* archive = nullptr;
  ~Zip() {
    if (archive) zip_discard(archive);  // read only: nothing to write back
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

// Reads a whole zip entry (metadata is small; sample chunks are read in pieces elsewhere).
bool read_entry(zip_t* z, const std::string& name, std::string& out) {
  zip_stat_t st;
  if (zip_stat(z, name.c_str(), 0, &st) != 0) return false;
  zip_file_t* f = zip_fopen(z, name.c_str(), 0);
  if (!f) return false;
  out.resize(static_cast<std::size_t>(st.size));
  const zip_int64_t got = zip_fread(f, out.data(), st.size);
  zip_fclose(f);
  return got == static_cast<zip_int64_t>(st.size);
}

// `metadata` is INI: "[device 1]" then key=value lines.
std::map<std::string, std::string> device_keys(const std::string& ini) {
  std::map<std::string, std::string> keys;
  std::istringstream in(ini);
  std::string line;
  bool in_device = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.starts_with("[")) {
      in_device = line == "[device 1]";
      continue;
    }
    const std::size_t eq = line.find('=');
    if (in_device && eq != std::string::npos) keys[line.substr(0, eq)] = line.substr(eq + 1);
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
  std::unique_ptr<SigrokFile> file(new SigrokFile());
  file->path_ = path;
  file->zip_ = std::make_unique<Zip>();
  int code = 0;
  file->zip_->archive = zip_open(path.c_str(), ZIP_RDONLY, &code);
  if (!file->zip_->archive) {
    zip_error_t ze;
    zip_error_init_with_code(&ze, code);
    *error = fmt::format("{}: not a readable zip: {}", path, zip_error_strerror(&ze));
    zip_error_fini(&ze);
    return nullptr;
  }
  zip_t* z = file->zip_->archive;
  std::string ini;
  if (!read_entry(z, "metadata", ini)) {
    *error = fmt::format("{}: no 'metadata' in the zip: not a sigrok session file", path);
    return nullptr;
  }
  auto keys = device_keys(ini);
  file->sample_rate_ = parse_sample_rate(keys["samplerate"]);
  if (file->sample_rate_ <= 0) {
    *error = fmt::format("{}: metadata: samplerate '{}' is not a rate", path, keys["samplerate"]);
    return nullptr;
  }
  const int probes = keys.count("total probes") ? std::atoi(keys["total probes"].c_str()) : 0;
  const int analogs = keys.count("total analog") ? std::atoi(keys["total analog"].c_str()) : 0;
  std::string prefix;
  if (probes > 0) {
    if (probes > 64) {
      *error = fmt::format("{}: metadata: {} logic channels (at most 64 supported)", path, probes);
      return nullptr;
    }
    file->unit_size_ = keys.count("unitsize") ? std::atoi(keys["unitsize"].c_str()) : 1;
    if (file->unit_size_ < 1 || file->unit_size_ > 8 || file->unit_size_ * 8 < probes) {
      *error = fmt::format("{}: metadata: unitsize {} does not hold {} channels", path,
                           file->unit_size_, probes);
      return nullptr;
    }
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
  const zip_int64_t entries = zip_get_num_entries(z, 0);
  for (zip_int64_t i = 0; i < entries; ++i) {
    const char* name = zip_get_name(z, static_cast<zip_uint64_t>(i), 0);
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

bool SigrokFile::read(const std::function<void(std::span<const std::uint64_t>)>& chunk,
                      std::string* error) {
  zip_t* z = zip_->archive;
  constexpr std::size_t kBlock = 1 << 16;  // bytes read at a time
  std::vector<std::uint8_t> raw(kBlock + 8);
  std::vector<std::uint64_t> samples;
  samples.reserve(kBlock);
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  // Analog traces need their range first: one pass for min/max, one to threshold.
  for (int pass = analog_ ? 0 : 1; pass < 2; ++pass) {
    const float threshold = (lo + hi) / 2;
    for (const std::string& name : chunks_) {
      zip_file_t* f = zip_fopen(z, name.c_str(), 0);
      if (!f) {
        *error = fmt::format("{}: {}: cannot open: {}", path_, name, zip_strerror(z));
        return false;
      }
      const std::size_t unit = analog_ ? sizeof(float) : static_cast<std::size_t>(unit_size_);
      std::size_t carried = 0;  // bytes of a sample split across two reads
      std::uint64_t offset = 0;
      for (;;) {
        const zip_int64_t got = zip_fread(f, raw.data() + carried, kBlock);
        if (got < 0) {
          *error = fmt::format("{}: {}: offset {}: damaged: {}", path_, name, offset,
                               zip_file_strerror(f));
          zip_fclose(f);
          return false;
        }
        if (got == 0) break;
        const std::size_t have = carried + static_cast<std::size_t>(got);
        const std::size_t whole = have / unit * unit;
        samples.clear();
        for (std::size_t at = 0; at < whole; at += unit) {
          if (analog_) {
            float v;
            std::memcpy(&v, raw.data() + at, sizeof v);
            if (pass == 0) {
              if (std::isfinite(v)) {
                lo = std::min(lo, v);
                hi = std::max(hi, v);
              }
            } else {
              samples.push_back(v > threshold ? 1 : 0);
            }
          } else {
            std::uint64_t word = 0;
            for (std::size_t b = 0; b < unit; ++b)
              word |= static_cast<std::uint64_t>(raw[at + b]) << (8 * b);
            samples.push_back(word);
          }
        }
        if (pass == 1 && !samples.empty()) chunk(samples);
        carried = have - whole;
        std::memmove(raw.data(), raw.data() + whole, carried);
        offset += static_cast<std::uint64_t>(got);
      }
      zip_fclose(f);
      if (carried != 0) {
        *error = fmt::format("{}: {}: ends inside a sample ({} stray bytes)", path_, name, carried);
        return false;
      }
    }
  }
  return true;
}

}  // namespace drivetap
