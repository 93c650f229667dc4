// Stats: the closing summary — frames, checksum verdicts, transactions, latency, anomaly counts.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/anomaly.hpp"
#include "core/message.hpp"
#include "core/transaction.hpp"

namespace drivetap {

// One station at the end of the run: the profile it was bound to and its last known state.
struct DriveSummary {
  std::size_t link = 0;
  int address = 0;
  std::string profile;       // profile id, "generic" when no family fits
  std::string profile_name;  // "ERMAN E-9P/9G"
  std::string binding;       // how: "bound with --drive", or the auto evidence
  std::string state;         // DriveState::summary(); empty when nothing was read
  std::uint64_t events = 0;
};

struct Stats {
  std::uint64_t bytes = 0;
  std::uint64_t frames = 0;
  std::uint64_t noise_records = 0;
  std::uint64_t noise_bytes = 0;
  std::array<std::uint64_t, 4> checksum{};  // by ChecksumVerdict
  // Telegrams with a good checksum that keep their protocol's plausibility rules
  // (good_telegram()): what a drive bus is made of; checksum[good] counts the rest too.
  std::uint64_t good_telegrams = 0;
  std::array<std::uint64_t, kOutcomeCount> outcomes{};  // by Outcome
  std::uint64_t transactions = 0;
  std::uint64_t latency_count = 0;
  TimeNs latency_sum = 0;
  TimeNs latency_min = std::numeric_limits<TimeNs>::max();
  TimeNs latency_max = 0;
  AnomalyCounts anomalies{};
  std::uint64_t anomaly_total = 0;
  TimeNs first_time = std::numeric_limits<TimeNs>::max();
  TimeNs last_time = std::numeric_limits<TimeNs>::min();
  std::vector<DriveSummary> drives;
  // What the source says about itself at the end (a serial port's kernel error counters, its
  // USB burst verdict): one line each, shown in the summary; empty for files.
  std::vector<std::string> source_notes;
  // Telegrams on channels whose times the source found carry no inter-frame silence (USB bursts,
  // Pipeline::distrust_silences()): their silence rules (t1.5, t3.5, the drives' timing rules)
  // not judged, and of them the replies whose latency is hidden for it.
  std::uint64_t silences_unjudged = 0;
  std::uint64_t latencies_unjudged = 0;
  // Bytes of IP flows with no drive protocol, left out of the decode (in no frame or noise).
  std::uint64_t left_out_bytes = 0;
  // With a display filter (-Y): its text, and how many of the frame and noise records it
  // selected and saw. Everything above counts every record all the same.
  std::string display_filter;
  std::uint64_t filter_matched = 0;
  std::uint64_t filter_records = 0;
  // Findings reported after their frame that -Y selected by their own record (their frame not
  // selected): printed, and so counted apart.
  std::uint64_t filter_late_findings = 0;

  void count_frame(const Message& m);
  // The same for a telegram of `size` bytes, the first starting at `first`, the last at `last`;
  // `plausible`: it has no `implausible` finding.
  void count_telegram(std::size_t size, ChecksumVerdict verdict, bool plausible, TimeNs first,
                      TimeNs last) {
    ++frames;
    bytes += size;
    ++checksum[static_cast<std::size_t>(verdict)];
    if (verdict == ChecksumVerdict::good && plausible) ++good_telegrams;
    first_time = std::min(first_time, first);
    last_time = std::max(last_time, last);
  }
  void count_noise(const Frame& f);
  void count_transaction(const Transaction& t);
  void count_anomaly(const Anomaly& a) { count_anomaly(a.kind); }
  void count_anomaly(AnomalyKind kind) {
    ++anomalies[static_cast<std::size_t>(kind)];
    ++anomaly_total;
  }
};

}  // namespace drivetap
