// Unit tests: libpcap and libzip loaded on first use (src/formats/shared_libraries.hpp).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "formats/shared_libraries.hpp"

using namespace drivetap;

namespace {

// Every function slot of a library, as untyped addresses (nullptr where not looked up).
std::vector<const void*> slots(const PcapLibrary& l) {
  return {reinterpret_cast<const void*>(l.fopen_offline_with_tstamp_precision),
          reinterpret_cast<const void*>(l.datalink),
          reinterpret_cast<const void*>(l.next_ex),
          reinterpret_cast<const void*>(l.file),
          reinterpret_cast<const void*>(l.geterr),
          reinterpret_cast<const void*>(l.close),
          reinterpret_cast<const void*>(l.open_dead_with_tstamp_precision),
          reinterpret_cast<const void*>(l.dump_fopen),
          reinterpret_cast<const void*>(l.dump),
          reinterpret_cast<const void*>(l.dump_flush)};
}
std::vector<const void*> slots(const ZipLibrary& l) {
  return {reinterpret_cast<const void*>(l.open),
          reinterpret_cast<const void*>(l.discard),
          reinterpret_cast<const void*>(l.stat),
          reinterpret_cast<const void*>(l.fopen),
          reinterpret_cast<const void*>(l.fread),
          reinterpret_cast<const void*>(l.fclose),
          reinterpret_cast<const void*>(l.get_num_entries),
          reinterpret_cast<const void*>(l.get_name),
          reinterpret_cast<const void*>(l.strerror),
          reinterpret_cast<const void*>(l.file_strerror),
          reinterpret_cast<const void*>(l.error_init_with_code),
          reinterpret_cast<const void*>(l.error_strerror),
          reinterpret_cast<const void*>(l.error_fini)};
}

}  // namespace

TEST(SharedLibraries, LibpcapLoadsWithEveryFunctionAndWorks) {
  const PcapLibrary& lib = pcap_library();
  ASSERT_TRUE(lib.loaded) << lib.error;
  EXPECT_TRUE(lib.error.empty());
  for (const void* f : slots(lib)) EXPECT_NE(f, nullptr);
  EXPECT_EQ(&pcap_library(), &lib);  // loaded once
  // The functions are libpcap's: a dead handle of link type 147 says so.
  pcap_t* p = lib.open_dead_with_tstamp_precision(147, 65535, PCAP_TSTAMP_PRECISION_NANO);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(lib.datalink(p), 147);
  lib.close(p);
}

TEST(SharedLibraries, LibzipLoadsWithEveryFunctionAndWorks) {
  const ZipLibrary& lib = zip_library();
  ASSERT_TRUE(lib.loaded) << lib.error;
  for (const void* f : slots(lib)) EXPECT_NE(f, nullptr);
  zip_error_t error;
  lib.error_init_with_code(&error, ZIP_ER_NOENT);
  EXPECT_STREQ(lib.error_strerror(&error), "No such file");
  lib.error_fini(&error);
  int code = 0;
  EXPECT_EQ(lib.open("/nonexistent/drivetap-test.sr", ZIP_RDONLY, &code), nullptr);
  EXPECT_EQ(code, ZIP_ER_NOENT);
}

TEST(SharedLibraries, AMissingLibraryIsNamedAndLeavesNoFunction) {
  PcapLibrary pcap;
  load_pcap_library("libdrivetap-no-such-library.so.0", pcap);
  EXPECT_FALSE(pcap.loaded);
  EXPECT_NE(pcap.error.find("cannot load libdrivetap-no-such-library.so.0 ("), std::string::npos)
      << pcap.error;
  for (const void* f : slots(pcap)) EXPECT_EQ(f, nullptr);
}

TEST(SharedLibraries, ALibraryWithoutAFunctionIsNamedAndLeavesNoFunction) {
  // libc is there, without any of libzip's functions: the first is named.
  ZipLibrary zip;
  load_zip_library("libc.so.6", zip);
  EXPECT_FALSE(zip.loaded);
  EXPECT_EQ(zip.error, "cannot load libc.so.6: it has no zip_open");
  for (const void* f : slots(zip)) EXPECT_EQ(f, nullptr);
  // A library with libpcap's first two functions alone (tests/fake_libpcap.cpp): the third is
  // named, and the two found are not kept.
  PcapLibrary half;
  load_pcap_library(DRIVETAP_FAKE_LIBPCAP, half);
  EXPECT_FALSE(half.loaded);
  EXPECT_EQ(half.error,
            fmt::format("cannot load {}: it has no pcap_next_ex", DRIVETAP_FAKE_LIBPCAP));
  for (const void* f : slots(half)) EXPECT_EQ(f, nullptr);
}
