// A library with libpcap's first two functions of PcapLibrary and none after: the loader must
// name the first one missing and keep none (tests/test_shared_libraries.cpp).
#include <pcap/pcap.h>

extern "C" pcap_t* pcap_fopen_offline_with_tstamp_precision(FILE*, u_int, char*) {
  return nullptr;
}
extern "C" int pcap_datalink(pcap_t*) {
  return 0;
}
