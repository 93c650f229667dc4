// libpcap and libzip loaded on first use (dlopen; why and what in shared_libraries.hpp).
#include "formats/shared_libraries.hpp"

#include <dlfcn.h>
#include <fmt/format.h>

#include <string>
#include <type_traits>
#include <utility>

namespace drivetap {
namespace {

// Opens `soname` for the lookups of `load`; the handle stays open for the life of the process.
template <class Library, class Load>
void load_library(const char* soname, Library& lib, Load&& load) {
  lib = Library{};
  void* handle = ::dlopen(soname, RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = ::dlerror();
    lib.error = fmt::format("cannot load {} ({})", soname, why ? why : "no reason given");
    return;
  }
  // find(name, slot): the function `name` into `slot`, with the type of the slot (the header's).
  bool all_found = true;
  auto find = [&](const char* name, auto& slot) {
    if (!all_found) return;
    void* address = ::dlsym(handle, name);
    if (!address) {
      lib.error = fmt::format("cannot load {}: it has no {}", soname, name);
      all_found = false;
      return;
    }
    // POSIX: a function's address from dlsym() converts to the function pointer type.
    slot = reinterpret_cast<std::remove_reference_t<decltype(slot)>>(address);
  };
  load(find);
  if (!all_found) {
    ::dlclose(handle);
    std::string error = std::move(lib.error);
    lib = Library{};  // no function of a library that is only half there
    lib.error = std::move(error);
    return;
  }
  lib.loaded = true;
}

}  // namespace

void load_pcap_library(const char* soname, PcapLibrary& lib) {
  load_library(soname, lib, [&](auto&& find) {
    find("pcap_fopen_offline_with_tstamp_precision", lib.fopen_offline_with_tstamp_precision);
    find("pcap_datalink", lib.datalink);
    find("pcap_next_ex", lib.next_ex);
    find("pcap_file", lib.file);
    find("pcap_geterr", lib.geterr);
    find("pcap_close", lib.close);
    find("pcap_open_dead_with_tstamp_precision", lib.open_dead_with_tstamp_precision);
    find("pcap_dump_fopen", lib.dump_fopen);
    find("pcap_dump", lib.dump);
    find("pcap_dump_flush", lib.dump_flush);
  });
}

void load_zip_library(const char* soname, ZipLibrary& lib) {
  load_library(soname, lib, [&](auto&& find) {
    find("zip_open", lib.open);
    find("zip_discard", lib.discard);
    find("zip_stat", lib.stat);
    find("zip_fopen", lib.fopen);
    find("zip_fread", lib.fread);
    find("zip_fclose", lib.fclose);
    find("zip_get_num_entries", lib.get_num_entries);
    find("zip_get_name", lib.get_name);
    find("zip_strerror", lib.strerror);
    find("zip_file_strerror", lib.file_strerror);
    find("zip_error_init_with_code", lib.error_init_with_code);
    find("zip_error_strerror", lib.error_strerror);
    find("zip_error_fini", lib.error_fini);
  });
}

const PcapLibrary& pcap_library() {
  static const PcapLibrary lib = [] {
    PcapLibrary l;
    load_pcap_library(DRIVETAP_PCAP_SONAME, l);
    return l;
  }();
  return lib;
}

const ZipLibrary& zip_library() {
  static const ZipLibrary lib = [] {
    ZipLibrary l;
    load_zip_library(DRIVETAP_LIBZIP_SONAME, l);
    return l;
  }();
  return lib;
}

}  // namespace drivetap
