// Structure-aware mutations for the logic-capture fuzz targets: random byte flips
// rarely make a well-formed header with an extreme value in it, which is where the crashes were
// (a 1 s timescale, a 1 Hz sample rate, duplicate keys, thousands of variables on one identifier,
// names of 64 KiB). Half the mutations rewrite the header with such values, half are libFuzzer's.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <string_view>

extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

namespace drivetap::fuzz {

template <std::size_t N>
const char* pick(std::mt19937& rng, const char* const (&choices)[N]) {
  return choices[rng() % N];
}

// Replaces the text between `key` and the next `until` (or appends "key value until").
inline void set_between(std::string& text, std::string_view key, std::string_view until,
                        std::string_view value) {
  const std::size_t at = text.find(key);
  if (at == std::string::npos) {
    text.insert(0, std::string(key) + std::string(value) + std::string(until));
    return;
  }
  const std::size_t from = at + key.size();
  const std::size_t end = text.find(until, from);
  text.replace(from, end == std::string::npos ? std::string::npos : end - from, value);
}

// A VCD header with an extreme timescale, many variables on one identifier, a long name or deep
// scopes; the value changes after $enddefinitions are kept.
inline std::string mutate_vcd_header(std::string text, std::mt19937& rng) {
  static const char* const kTimescales[] = {" 1 s ",       " 100 s ", " 1 fs ",
                                            " 10 ps ",     " 1 ms ",  " 100 ns ",
                                            " 1000000 s ", " 0 s ",   " 3 us "};
  switch (rng() % 4) {
    case 0:
      set_between(text, "$timescale", "$end", pick(rng, kTimescales));
      break;
    case 1: {  // variables sharing the first identifier
      std::string vars;
      const std::size_t n = 1 + rng() % 600;
      for (std::size_t i = 0; i < n; ++i) vars += "$var wire 1 ! v" + std::to_string(i) + " $end\n";
      const std::size_t at = text.find("$enddefinitions");
      text.insert(at == std::string::npos ? 0 : at, vars);
      break;
    }
    case 2: {  // a long name (a channel name past 64 bytes, with bytes that are no UTF-8)
      std::string name(1 + rng() % 5000, 'n');
      name[rng() % name.size()] = static_cast<char>(0x80 + rng() % 0x80);
      const std::size_t at = text.find("$enddefinitions");
      text.insert(at == std::string::npos ? 0 : at, "$var wire 1 ! " + name + " $end\n");
      break;
    }
    default: {  // deep scopes
      std::string scopes;
      const std::size_t depth = 1 + rng() % 300;
      for (std::size_t i = 0; i < depth; ++i) scopes += "$scope module s $end\n";
      const std::size_t at = text.find("$var");
      text.insert(at == std::string::npos ? 0 : at, scopes);
      break;
    }
  }
  return text;
}

// sigrok `metadata` INI text with an extreme or duplicated key.
inline std::string mutate_sigrok_metadata(std::string text, std::mt19937& rng) {
  static const char* const kRates[] = {
      "1 Hz",   "3 Hz",  "0.5 Hz", "7 Hz", "100 GHz", "1e30 Hz", "18446744073709551615 Hz",
      "-1 MHz", "1 MHz", "24 MHz"};
  static const char* const kCounts[] = {"0",  "1",  "2",    "8",  "9",
                                        "64", "65", "4096", "-1", "2147483648"};
  switch (rng() % 4) {
    case 0:
      set_between(text, "samplerate=", "\n", pick(rng, kRates));
      break;
    case 1:  // a duplicate key: the last one wins
      text += std::string("samplerate=") + pick(rng, kRates) + "\n";
      break;
    case 2:
      set_between(text, rng() % 2 ? "total probes=" : "unitsize=", "\n", pick(rng, kCounts));
      break;
    default: {
      std::string name(1 + rng() % 5000, 'p');
      name[rng() % name.size()] = static_cast<char>(rng() % 0x20);
      text += "probe" + std::to_string(1 + rng() % 9) + "=" + name + "\n";
      break;
    }
  }
  return text;
}

// Writes `text` over the input if it fits; the size used (0: it did not fit).
inline std::size_t store(std::string_view text, std::uint8_t* data, std::size_t max_size) {
  if (text.empty() || text.size() > max_size) return 0;
  std::memcpy(data, text.data(), text.size());
  return text.size();
}

}  // namespace drivetap::fuzz
