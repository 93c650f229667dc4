// libpcap and libzip, loaded the first time a classic pcap file or a sigrok session needs them
// (dlopen), not at every start (docs/design.md).
//
// Linked the usual way, the two and the 13 libraries they bring (libdbus, libsystemd, libgcrypt,
// libcrypto, ...) were mapped and relocated before main() on every run, a large part of a start,
// where most runs read pcapng, byte logs or serial ports and use neither. Each is opened by its
// soname, read from the library CMake found (DRIVETAP_PCAP_SONAME, DRIVETAP_LIBZIP_SONAME), and
// each function drivetap calls is looked up once, with the type its header declares.
#pragma once

#include <pcap/pcap.h>
#include <zip.h>

#include <string>

namespace drivetap {

// libpcap's functions drivetap calls (reading classic pcap, writing it with -F pcap).
struct PcapLibrary {
  bool loaded = false;
  std::string error;  // why not: "cannot load libpcap.so.0.8 (...)"
  decltype(&::pcap_fopen_offline_with_tstamp_precision) fopen_offline_with_tstamp_precision{};
  decltype(&::pcap_datalink) datalink{};
  decltype(&::pcap_next_ex) next_ex{};
  decltype(&::pcap_file) file{};
  decltype(&::pcap_geterr) geterr{};
  decltype(&::pcap_close) close{};
  decltype(&::pcap_open_dead_with_tstamp_precision) open_dead_with_tstamp_precision{};
  decltype(&::pcap_dump_fopen) dump_fopen{};
  decltype(&::pcap_dump) dump{};
  decltype(&::pcap_dump_flush) dump_flush{};
};

// libzip's functions drivetap calls (reading sigrok session files).
struct ZipLibrary {
  bool loaded = false;
  std::string error;
  decltype(&::zip_open) open{};
  decltype(&::zip_discard) discard{};
  decltype(&::zip_stat) stat{};
  decltype(&::zip_fopen) fopen{};
  decltype(&::zip_fread) fread{};
  decltype(&::zip_fclose) fclose{};
  decltype(&::zip_get_num_entries) get_num_entries{};
  decltype(&::zip_get_name) get_name{};
  decltype(&::zip_strerror) strerror{};
  decltype(&::zip_file_strerror) file_strerror{};
  decltype(&::zip_error_init_with_code) error_init_with_code{};
  decltype(&::zip_error_strerror) error_strerror{};
  decltype(&::zip_error_fini) error_fini{};
};

// Loaded on the first call, from any thread; the same result ever after (a library that failed to
// load is not tried again).
const PcapLibrary& pcap_library();
const ZipLibrary& zip_library();

// The loading itself, for any soname (tests: a library that is not there): fills `lib` from
// `soname`, or sets lib.error naming the library, and the symbol if one is missing.
void load_pcap_library(const char* soname, PcapLibrary& lib);
void load_zip_library(const char* soname, ZipLibrary& lib);

}  // namespace drivetap
