// Value Change Dump reader (src/sources/logic/vcd_file.hpp).
#include "sources/logic/vcd_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>

#include <sys/stat.h>

#include "core/time.hpp"
#include "sources/logic/sigrok_file.hpp"  // parse_sample_rate, for sigrok's "... at 2 MHz" comment

namespace drivetap {

namespace {

constexpr std::size_t kReadBytes = 1 << 20;   // one fread
constexpr std::size_t kMaxToken = 64 * 1024;  // identifiers, values, words
constexpr std::size_t kMaxIdentifier = 256;
constexpr std::size_t kMaxName = 1024;  // scopes and reference, as declared
constexpr std::size_t kMaxVariables = 4096;
constexpr std::size_t kMaxScopes = 4096;
constexpr std::size_t kMaxScopeDepth = 32;
constexpr std::size_t kMaxKeywordWords = 16;  // $var type size id name [bits] ... $end
constexpr std::size_t kMaxComment = 512;      // of a header $comment, kept for the sigrok rate
constexpr std::uint64_t kMaxSampleRate = 1'000'000'000;  // see the header: finer is divided

// What the first byte of a body token makes of it.
enum Kind : std::uint8_t { kBad, kLow, kHigh, kKeep, kVector, kReal, kTime, kKeyword };

constexpr std::array<Kind, 256> make_kinds() {
  std::array<Kind, 256> k{};
  k['0'] = k['l'] = k['L'] = kLow;  // L/H: weak 0/1 (VHDL std_logic from GHDL)
  k['1'] = k['h'] = k['H'] = kHigh;
  for (char c : {'x', 'X', 'z', 'Z', 'u', 'U', 'w', 'W', '-'})
    k[static_cast<unsigned char>(c)] = kKeep;
  k['b'] = k['B'] = kVector;
  k['r'] = k['R'] = kReal;
  k['s'] = k['S'] = kReal;  // a string value (GTKWave's extension): skipped like a real
  k['#'] = kTime;
  k['$'] = kKeyword;
  return k;
}
constexpr std::array<Kind, 256> kKinds = make_kinds();

constexpr std::array<bool, 256> make_spaces() {
  std::array<bool, 256> s{};
  for (char c : {' ', '\t', '\n', '\r', '\v', '\f'}) s[static_cast<unsigned char>(c)] = true;
  return s;
}
constexpr std::array<bool, 256> kSpace = make_spaces();

// A token as an error message shows it: at most 40 bytes, unprintable bytes as '?'.
std::string shown(std::string_view token) {
  std::string s(token.substr(0, 40));
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x21 || static_cast<unsigned char>(c) > 0x7E) c = '?';
  if (token.size() > 40) s += "...";
  return s;
}

enum class Number { ok, not_a_number, too_big };

Number parse_u64(std::string_view s, std::uint64_t& value) {
  if (s.empty()) return Number::not_a_number;
  value = 0;
  bool overflow = false;
  for (char c : s) {
    if (c < '0' || c > '9') return Number::not_a_number;
    const auto d = static_cast<std::uint64_t>(c - '0');
    if (value > (std::numeric_limits<std::uint64_t>::max() - d) / 10) overflow = true;
    value = value * 10 + d;
  }
  return overflow ? Number::too_big : Number::ok;
}

std::uint64_t pow10(int n) {
  std::uint64_t v = 1;
  while (n-- > 0) v *= 10;
  return v;
}

// "1us", "10 ns" (words joined), "100ps" -> the unit as a power of ten of femtoseconds.
bool parse_timescale(const std::string& text, int& fs_exponent) {
  std::size_t digits = 0;
  while (digits < text.size() && text[digits] >= '0' && text[digits] <= '9') ++digits;
  const std::string magnitude = text.substr(0, digits), unit = text.substr(digits);
  int exponent;
  if (magnitude == "1")
    exponent = 0;
  else if (magnitude == "10")
    exponent = 1;
  else if (magnitude == "100")
    exponent = 2;
  else
    return false;
  static constexpr std::pair<const char*, int> kUnits[] = {{"s", 15}, {"ms", 12}, {"us", 9},
                                                           {"ns", 6}, {"ps", 3},  {"fs", 0}};
  for (const auto& [name, e] : kUnits)
    if (unit == name) {
      fs_exponent = exponent + e;
      return true;
    }
  return false;
}

// sigrok's header comment "Acquisition with 8/8 channels at 2 MHz" -> 2000000; 0 when none.
std::uint64_t sigrok_rate(const std::string& comment) {
  if (comment.find("Acquisition with ") == std::string::npos) return 0;
  const std::size_t at = comment.rfind(" at ");
  if (at == std::string::npos) return 0;
  const double rate = parse_sample_rate(comment.substr(at + 4));
  if (!(rate >= 1) || rate > static_cast<double>(kMaxSampleRate) || rate != std::floor(rate))
    return 0;
  return static_cast<std::uint64_t>(rate);
}

}  // namespace

// Whitespace-separated tokens of the file, read in big pieces; a token stays valid until the
// next call. Tokens never span a newline, so lines are counted while skipping whitespace.
class VcdFile::Tokens {
 public:
  // `read_bytes` per fread; room behind them for the start of a token that runs on.
  Tokens(std::FILE* file, std::size_t read_bytes)
      : file_(file), read_bytes_(read_bytes), buffer_(new char[read_bytes + kMaxToken]) {}
  ~Tokens() { std::fclose(file_); }
  Tokens(const Tokens&) = delete;
  Tokens& operator=(const Tokens&) = delete;

  // The next token, empty at the end of the file. False with *why on a read error or a token
  // longer than kMaxToken.
  bool next(std::string_view& out, std::string* why) {
    for (;;) {
      while (pos_ < end_) {
        const auto c = static_cast<unsigned char>(buffer_[pos_]);
        if (!kSpace[c]) break;
        line_ += c == '\n';
        ++pos_;
      }
      if (pos_ < end_) break;
      if (eof_) {
        out = {};
        return true;
      }
      base_ += end_;
      pos_ = end_ = 0;
      if (!fill(why)) return false;
    }
    std::size_t start = pos_;
    for (;;) {
      while (pos_ < end_ && !kSpace[static_cast<unsigned char>(buffer_[pos_])]) ++pos_;
      if (pos_ - start > kMaxToken) {
        *why = fmt::format("a word longer than {} bytes", kMaxToken);
        return false;
      }
      if (pos_ < end_ || eof_) break;
      // The token runs on past this piece: move it to the front and read on behind it.
      const std::size_t have = pos_ - start;
      std::memmove(buffer_.get(), buffer_.get() + start, have);
      base_ += start;
      start = 0;
      pos_ = end_ = have;
      if (!fill(why)) return false;
    }
    out = std::string_view(buffer_.get() + start, pos_ - start);
    return true;
  }

  [[nodiscard]] std::uint64_t line() const { return line_; }
  [[nodiscard]] std::uint64_t offset() const { return base_ + pos_; }

  bool seek(std::uint64_t offset, std::uint64_t line, std::string* why) {
    if (offset > static_cast<std::uint64_t>(std::numeric_limits<off_t>::max()) ||
        fseeko(file_, static_cast<off_t>(offset), SEEK_SET) != 0) {
      *why = fmt::format("cannot seek back to the value changes: {}", std::strerror(errno));
      return false;
    }
    base_ = offset;
    pos_ = end_ = 0;
    eof_ = false;
    line_ = line;
    return true;
  }

 private:
  // Appends up to read_bytes_ behind end_ (there is always room: end_ <= kMaxToken here).
  bool fill(std::string* why) {
    const std::size_t got = std::fread(buffer_.get() + end_, 1, read_bytes_, file_);
    if (got == 0) {
      if (std::ferror(file_)) {
        *why = fmt::format("read error: {}", std::strerror(errno));
        return false;
      }
      eof_ = true;
    }
    end_ += got;
    return true;
  }

  std::FILE* file_;
  std::size_t read_bytes_;
  std::unique_ptr<char[]> buffer_;  // not zeroed: only what fread wrote is read
  std::size_t pos_ = 0, end_ = 0;   // unread bytes: buffer_[pos_, end_)
  std::uint64_t base_ = 0;          // file offset of buffer_[0]
  std::uint64_t line_ = 1;
  bool eof_ = false;
};

VcdFile::~VcdFile() = default;

std::string VcdFile::where() const {
  return fmt::format("{}: line {}", path_, tokens_->line());
}

int VcdFile::slot_of(std::string_view id) const {
  if (id.size() == 1) return slot_by_byte_[static_cast<unsigned char>(id[0])];
  if (id.size() == 2) {
    if (slot_by_pair_.empty()) return -1;
    return slot_by_pair_[static_cast<unsigned char>(id[0]) << 8 |
                         static_cast<unsigned char>(id[1])];
  }
  const auto it = std::lower_bound(long_ids_.begin(), long_ids_.end(), id);
  if (it == long_ids_.end() || *it != id) return -1;
  return long_slots_[static_cast<std::size_t>(it - long_ids_.begin())];
}

int VcdFile::add_slot(std::string_view id) {
  const auto slot = static_cast<std::int32_t>(slot_is_channel_.size());
  slot_is_channel_.push_back(false);
  if (id.size() == 1) {
    slot_by_byte_[static_cast<unsigned char>(id[0])] = slot;
  } else if (id.size() == 2) {
    if (slot_by_pair_.empty()) slot_by_pair_.assign(1 << 16, -1);
    slot_by_pair_[static_cast<unsigned char>(id[0]) << 8 | static_cast<unsigned char>(id[1])] =
        slot;
  } else {
    const auto it = std::lower_bound(long_ids_.begin(), long_ids_.end(), id);
    const auto at = it - long_ids_.begin();
    long_ids_.insert(it, std::string(id));
    long_slots_.insert(long_slots_.begin() + at, slot);
  }
  return slot;
}

std::unique_ptr<VcdFile> VcdFile::open(const std::string& path, std::string* error,
                                       std::size_t read_bytes) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    *error = fmt::format("{}: cannot open: {}", path, std::strerror(errno));
    return nullptr;
  }
  // A small file gets a small buffer (a capture of a few KiB is common, and fuzzing opens many).
  if (read_bytes == 0 || read_bytes > kReadBytes) {
    read_bytes = kReadBytes;
    struct stat st;
    if (fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode) && st.st_size >= 0 &&
        static_cast<std::uint64_t>(st.st_size) < kReadBytes)
      read_bytes = std::max<std::size_t>(static_cast<std::size_t>(st.st_size) + 1, 4096);
  }
  std::unique_ptr<VcdFile> file(new VcdFile());
  file->path_ = path;
  file->tokens_ = std::make_unique<Tokens>(f, read_bytes);
  file->slot_by_byte_.assign(256, -1);
  if (!file->read_header(error)) return nullptr;
  return file;
}

bool VcdFile::read_header(std::string* error) {
  struct Scope {
    int parent;
    std::size_t depth;   // 1 for a top-level scope
    std::size_t length;  // of the names from the top, with a '.' after each
    std::string name;
  };
  struct Variable {
    int scope;
    std::string reference;
    int slot;
  };
  std::vector<Scope> scopes;
  std::vector<Variable> variables;  // the 1-bit ones
  std::size_t declared = 0;
  int scope = -1;
  int fs_exponent = -1;
  std::uint64_t stated_rate = 0;
  std::vector<std::string> words;
  std::string_view token;
  std::string why;
  auto fail = [&](std::uint64_t line, const std::string& reason) {
    *error = fmt::format("{}: line {}: {}", path_, line, reason);
    return false;
  };
  bool first = true;
  for (;;) {
    if (!tokens_->next(token, &why)) return fail(tokens_->line(), why);
    if (token.empty())
      return fail(tokens_->line(), "the file ends inside the header (no $enddefinitions)");
    if (first && token.starts_with("\xEF\xBB\xBF")) token.remove_prefix(3);  // a UTF-8 mark
    first = false;
    if (token.empty()) continue;
    const std::uint64_t line = tokens_->line();
    if (token[0] != '$')
      return fail(line, fmt::format("'{}' outside a header section ($var ... $end)", shown(token)));
    if (token == "$end") continue;  // a stray one closes nothing
    const std::string keyword(token);
    // The section's words up to $end: kept for the sections read here, skipped for the others
    // ($date, $version, unknown ones); a header $comment is kept in part, for sigrok's rate.
    const bool keep = keyword == "$var" || keyword == "$scope" || keyword == "$upscope" ||
                      keyword == "$timescale" || keyword == "$enddefinitions";
    const bool comment = keyword == "$comment";
    std::string text;
    words.clear();
    for (;;) {
      if (!tokens_->next(token, &why)) return fail(tokens_->line(), why);
      if (token.empty())
        return fail(line,
                    fmt::format("{} is not closed by $end before the end of the file", keyword));
      if (token == "$end") break;
      if (keep) {
        if (words.size() == kMaxKeywordWords)
          return fail(line, fmt::format("{} has more than {} words before $end", keyword,
                                        kMaxKeywordWords));
        words.emplace_back(token);
      } else if (comment && text.size() < kMaxComment) {
        text += text.empty() ? "" : " ";
        text += token.substr(0, kMaxComment);
      }
    }
    if (comment) {
      if (const std::uint64_t rate = sigrok_rate(text)) stated_rate = rate;
    } else if (keyword == "$timescale") {
      std::string joined;
      for (const std::string& w : words) joined += w;
      if (!parse_timescale(joined, fs_exponent))
        return fail(line, fmt::format("$timescale '{}' is not 1, 10 or 100 s, ms, us, ns, ps or fs",
                                      shown(joined)));
      if (fs_exponent > 15)
        return fail(line,
                    fmt::format("$timescale {} is coarser than 1 s: no whole sample rate", joined));
    } else if (keyword == "$scope") {
      const std::string name = words.size() >= 2 ? words[1] : words.empty() ? "" : words[0];
      const std::size_t depth = scope < 0 ? 1 : scopes[static_cast<std::size_t>(scope)].depth + 1;
      const std::size_t length =
          (scope < 0 ? 0 : scopes[static_cast<std::size_t>(scope)].length) + name.size() + 1;
      if (depth > kMaxScopeDepth)
        return fail(line, fmt::format("scopes nested deeper than {}", kMaxScopeDepth));
      if (scopes.size() == kMaxScopes)
        return fail(line, fmt::format("more than {} scopes", kMaxScopes));
      if (length > kMaxName)
        return fail(line, fmt::format("scope names longer than {} bytes", kMaxName));
      scopes.push_back({scope, depth, length, name});
      scope = static_cast<int>(scopes.size() - 1);
    } else if (keyword == "$upscope") {
      // One too many is harmless: the names stay at the top.
      if (scope >= 0) scope = scopes[static_cast<std::size_t>(scope)].parent;
    } else if (keyword == "$var") {
      if (words.size() < 4)
        return fail(line, "$var needs a type, a size, an identifier and a name before $end");
      if (++declared > kMaxVariables)
        return fail(line, fmt::format("more than {} variables", kMaxVariables));
      std::uint64_t size = 0;
      if (parse_u64(words[1], size) != Number::ok || size == 0)
        return fail(line, fmt::format("$var size '{}' is not a bit count", shown(words[1])));
      const std::string& id = words[2];
      if (id.size() > kMaxIdentifier)
        return fail(line, fmt::format("identifier longer than {} bytes", kMaxIdentifier));
      std::string reference = words[3];
      for (std::size_t w = 4; w < words.size(); ++w)
        reference += (words[w].starts_with("[") ? "" : " ") + words[w];
      const std::size_t length =
          (scope < 0 ? 0 : scopes[static_cast<std::size_t>(scope)].length) + reference.size();
      if (length > kMaxName)
        return fail(line, fmt::format("variable name longer than {} bytes", kMaxName));
      int slot = slot_of(id);
      if (slot < 0) slot = add_slot(id);
      const std::string& type = words[0];
      // Reals, events and strings have no logic level, whatever size they claim.
      const bool level = size == 1 && type != "real" && type != "realtime" && type != "shortreal" &&
                         type != "event" && type != "string";
      if (level) {
        slot_is_channel_[static_cast<std::size_t>(slot)] = true;
        variables.push_back({scope, std::move(reference), slot});
      } else {
        ++skipped_variables_;
      }
    } else if (keyword == "$enddefinitions") {
      body_offset_ = tokens_->offset();
      body_line_ = tokens_->line();
      if (fs_exponent < 0)
        return fail(line, "no $timescale in the header: the time unit is unknown");
      if (variables.empty())
        return fail(line, fmt::format("no 1-bit variable to read ({} declared, wider ones and "
                                      "reals are skipped)",
                                      declared));
      break;
    }
  }

  // Rate: see the header. The timescale's own rate is 10^(15 - fs_exponent) Hz.
  const std::uint64_t timescale_rate = pow10(15 - fs_exponent);
  timescale_rate_ = timescale_rate;
  if (stated_rate != 0 && stated_rate <= timescale_rate) {
    sample_rate_ = stated_rate;
    if (timescale_rate % stated_rate == 0)
      divider_ = timescale_rate / stated_rate;
    else
      divider_ = 0;  // sigrok rounded each sample's time to a tick: rounding back recovers it
  } else if (timescale_rate > kMaxSampleRate) {
    divider_ = timescale_rate / kMaxSampleRate;
    sample_rate_ = kMaxSampleRate;
  } else {
    divider_ = 1;
    sample_rate_ = timescale_rate;
  }

  // Names below the scopes every channel shares.
  auto is_within = [&](int inner, int outer) {
    if (outer < 0) return true;
    while (inner >= 0 && scopes[static_cast<std::size_t>(inner)].depth >
                             scopes[static_cast<std::size_t>(outer)].depth)
      inner = scopes[static_cast<std::size_t>(inner)].parent;
    return inner == outer;
  };
  int shared = variables.front().scope;
  for (const Variable& v : variables)
    while (!is_within(v.scope, shared)) shared = scopes[static_cast<std::size_t>(shared)].parent;
  for (const Variable& v : variables) {
    std::string name = v.reference;
    for (int s = v.scope; s >= 0 && s != shared; s = scopes[static_cast<std::size_t>(s)].parent)
      name = scopes[static_cast<std::size_t>(s)].name + "." + name;
    channels_.push_back(std::move(name));
    channel_slot_.push_back(v.slot);
  }
  return true;
}

std::uint64_t VcdFile::to_sample(std::uint64_t time) const {
  if (divider_ != 0) return time / divider_;
  // round(time x rate / timescale rate); the rate is below the timescale's, so this fits.
  const unsigned __int128 scaled =
      static_cast<unsigned __int128>(time) * sample_rate_ + timescale_rate_ / 2;
  return static_cast<std::uint64_t>(scaled / timescale_rate_);
}

bool VcdFile::rewind_body(std::string* error) {
  std::string why;
  if (!tokens_->seek(body_offset_, body_line_, &why)) {
    *error = fmt::format("{}: {}", path_, why);
    return false;
  }
  have_time_ = false;
  time_ = now_ = emitted_ = 0;
  return true;
}

bool VcdFile::select(const std::vector<std::size_t>& channels, std::string* error) {
  for (std::size_t c : channels)
    if (c >= channels_.size()) {
      *error = fmt::format("{}: no channel {} (it has {})", path_, c, channels_.size());
      return false;
    }
  done_ = true;
  selected_ = channels;
  const std::size_t n = channels.size();
  first_selected_.assign(slot_is_channel_.size(), -1);
  next_selected_.assign(n, -1);
  for (std::size_t k = n; k-- > 0;) {
    const auto slot = static_cast<std::size_t>(channel_slot_[channels[k]]);
    next_selected_[k] = first_selected_[slot];
    first_selected_[slot] = static_cast<std::int32_t>(k);
  }
  level_.assign(n, 1);  // a channel that never gets a level: an idle UART line
  known_.assign(n, 0);
  touched_.assign(n, 0);
  touched_list_.clear();
  run_start_.assign(n, 0);
  // A first pass learns each channel's first level, which also covers the time before it. It
  // stops as soon as every selected channel has one (at #0 in nearly every file); an error it
  // meets is reported by the real pass, in its place.
  unknown_ = n;
  if (!rewind_body(error)) return false;
  if (unknown_ > 0) {
    std::string ignored;
    scan(nullptr, &ignored);
  }
  value_ = level_;
  if (!rewind_body(error)) return false;
  done_ = false;
  return true;
}

// Changes at sample `at` take effect: a channel whose value differs ends its run there.
void VcdFile::commit(std::uint64_t at, RunBlock& block) {
  for (const std::int32_t signed_k : touched_list_) {
    const auto k = static_cast<std::size_t>(signed_k);
    touched_[k] = 0;
    if (value_[k] == level_[k]) continue;
    if (at > run_start_[k]) block.runs[k].push_back({level_[k] != 0, at - run_start_[k]});
    level_[k] = value_[k];
    run_start_[k] = at;
  }
  touched_list_.clear();
}

int VcdFile::scan(RunBlock* block, std::string* error) {
  const bool first_pass = block == nullptr;
  auto budget = static_cast<std::int64_t>(block_tokens_);
  const std::uint64_t max_sample =
      static_cast<std::uint64_t>(kTimeLimit / kNsPerSecond) * sample_rate_;
  std::string_view token;
  std::string why;
  auto fail = [&](const std::string& reason) {
    *error = fmt::format("{}: {}", where(), reason);
    return -1;
  };
  for (;; --budget) {
    if (!tokens_->next(token, &why)) return fail(why);
    if (token.empty()) return 0;
    std::uint8_t value;
    std::string_view id;
    switch (kKinds[static_cast<unsigned char>(token[0])]) {
      case kTime: {
        std::uint64_t t = 0;
        const Number number = parse_u64(token.substr(1), t);
        if (number == Number::not_a_number)
          return fail(fmt::format("'{}' is not a time (#digits)", shown(token)));
        if (number == Number::too_big)
          return fail(fmt::format("time {} does not fit 64 bits", shown(token)));
        if (have_time_ && t < time_)
          return fail(fmt::format("time #{} goes back (after #{})", t, time_));
        const std::uint64_t sample = to_sample(t);
        if (sample >= max_sample)
          return fail(fmt::format("time #{} is beyond the {} s a capture may last", t,
                                  kTimeLimit / kNsPerSecond));
        time_ = t;
        have_time_ = true;
        if (sample > now_) {
          if (!first_pass) commit(now_, *block);
          now_ = sample;
          if (!first_pass && budget <= 0 && now_ > block->begin) return 1;
        }
        continue;
      }
      case kLow:
      case kHigh:
      case kKeep: {
        const Kind kind = kKinds[static_cast<unsigned char>(token[0])];
        value = kind == kLow ? 0 : kind == kHigh ? 1 : 2;
        id = token.substr(1);
        if (id.empty()) return fail(fmt::format("value '{}' without an identifier", shown(token)));
        break;
      }
      case kVector:
      case kReal: {
        // The value, then its identifier as the next token. A 1-bit variable takes the last bit.
        value = 2;
        if (token[0] == 'b' || token[0] == 'B') {
          const Kind last = kKinds[static_cast<unsigned char>(token.back())];
          value = last == kLow ? 0 : last == kHigh ? 1 : 2;
        }
        if (!tokens_->next(id, &why)) return fail(why);
        if (id.empty()) return fail("the file ends between a value and its identifier");
        break;
      }
      case kKeyword:
        if (token == "$end" || token == "$dumpvars" || token == "$dumpall" || token == "$dumpon" ||
            token == "$dumpoff")
          continue;  // their contents are ordinary value changes
        if (token == "$comment") {
          do {
            if (!tokens_->next(token, &why)) return fail(why);
          } while (!token.empty() && token != "$end");
          if (token.empty()) return 0;
          continue;
        }
        return fail(fmt::format("'{}' among the value changes", shown(token)));
      case kBad:
      default:
        return fail(fmt::format("'{}' is not a value change", shown(token)));
    }
    const int slot = slot_of(id);
    if (slot < 0) return fail(fmt::format("value for '{}', which no $var declares", shown(id)));
    if (value == 2) continue;
    for (std::int32_t k = first_selected_[static_cast<std::size_t>(slot)]; k >= 0;
         k = next_selected_[static_cast<std::size_t>(k)]) {
      const auto i = static_cast<std::size_t>(k);
      --budget;  // a block is bounded by the runs it may hold: one identifier can feed thousands
      if (first_pass) {
        if (known_[i]) continue;
        known_[i] = 1;
        level_[i] = value;
        if (--unknown_ == 0) return 0;
      } else {
        value_[i] = value;
        if (!touched_[i]) {
          touched_[i] = 1;
          touched_list_.push_back(k);
        }
      }
    }
  }
}

bool VcdFile::next_block(RunBlock& block, std::string* error) {
  if (done_) return false;
  block.begin = emitted_;
  block.runs.assign(selected_.size(), {});
  const int result = scan(&block, error);
  if (result < 0) {
    done_ = true;
    return false;
  }
  if (result == 0) {
    commit(now_, block);  // values at the last time stamp last no sample
    done_ = true;
  }
  const std::uint64_t end = now_;
  if (end <= block.begin) return false;
  for (std::size_t k = 0; k < selected_.size(); ++k) {
    if (end > run_start_[k]) block.runs[k].push_back({level_[k] != 0, end - run_start_[k]});
    run_start_[k] = end;
  }
  block.end = emitted_ = end;
  return true;
}

}  // namespace drivetap
