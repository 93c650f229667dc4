// Shared by the libFuzzer targets: a sink that discards every record (checking only the
// pipeline's contracts on the way), and the `drivetap read` loop over any ByteSource.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <span>
#include <vector>

#include "pipeline/options.hpp"
#include "pipeline/pipeline.hpp"
#include "sources/source.hpp"

namespace drivetap::fuzz {

[[noreturn]] inline void contract_broken(const char* what) {
  std::fprintf(stderr, "drivetap fuzz: contract broken: %s\n", what);
  std::abort();
}

// Every field of a decoded frame must lie inside the frame's bytes.
inline void check_field_spans(const Message& m) {
  for (const FieldNode& n : m.fields) {
    if (n.desc == nullptr) contract_broken("field node without descriptor");
    if (std::size_t{n.offset} + n.length > m.bytes.size())
      contract_broken("field span beyond the frame's bytes");
  }
}

// Discards everything (memory stays bounded), but checks what the stage headers promise: the
// framer covers every byte exactly once (frame.hpp, rtu_framer.hpp), field spans lie inside
// their frame, and finish() emits exactly one summary.
struct DiscardSink final : Sink {
  std::uint64_t framed_bytes = 0;
  std::uint64_t left_out_bytes = 0;
  int summaries = 0;
  void on_frame(const Message& m) override {
    if (m.frame.events.empty()) contract_broken("empty frame");
    if (m.bytes.size() != m.frame.events.size()) contract_broken("message bytes != frame events");
    framed_bytes += m.frame.events.size();
    check_field_spans(m);
  }
  void on_noise(const Frame& f) override {
    if (f.events.empty()) contract_broken("empty noise record");
    framed_bytes += f.events.size();
  }
  void on_anomaly(const Anomaly&) override {}
  void on_transaction(const Transaction&) override {}
  void on_summary(const Stats& s) override {
    ++summaries;
    left_out_bytes = s.left_out_bytes;
  }
  bool flush() override { return true; }
};

// Pushes events through a pipeline and checks the byte accounting at the end.
class CheckedRun {
 public:
  CheckedRun(const PipelineOptions& options, const ChannelTable& channels)
      : pipeline_(options, channels, sink_) {}
  void push_batch(std::span<const ByteEvent> events) {
    pushed_ += events.size();
    pipeline_.push_batch(events);
  }
  void push(const ByteEvent& e) {
    ++pushed_;
    pipeline_.push(e);
  }
  void report(const Anomaly& a) { pipeline_.report(a); }
  void finish() {
    pipeline_.finish();
    pipeline_.finish();  // idempotent by contract
    if (sink_.summaries != 1) contract_broken("finish() did not emit exactly one summary");
    // (Bytes of an IP flow with no drive protocol are left out of the decode, and counted so.)
    if (sink_.framed_bytes + sink_.left_out_bytes != pushed_)
      contract_broken("frames, noise and left-out flows do not cover every pushed byte once");
  }

 private:
  DiscardSink sink_;
  Pipeline pipeline_;
  std::uint64_t pushed_ = 0;
};

// The built-in drive profiles, as `drivetap read` binds them by default (--drive auto): the
// binder, the drive-level reading and the timeline run on every fuzz input too.
inline const std::vector<const DriveProfile*>& builtin_candidates() {
  static const std::vector<DriveProfile> profiles = [] {
    ProfileError e;
    auto loaded = load_builtin_profiles(&e);
    if (!loaded) contract_broken("a built-in drive profile does not load");
    return std::move(*loaded);
  }();
  static const std::vector<const DriveProfile*> pointers = [] {
    std::vector<const DriveProfile*> out;
    for (const DriveProfile& p : profiles) out.push_back(&p);
    return out;
  }();
  return pointers;
}

// The loop of `drivetap read` (src/app/read.cpp, run_read) over one source.
inline void run_source(ByteSource& source, ChannelTable& channels) {
  if (!source.read_header()) return;
  std::string error;
  const auto options = resolve_pipeline_options(source.settings(), {}, &error);
  if (!options) return;  // the CLI refuses to run such a capture too
  PipelineOptions p = *options;
  p.auto_candidates = builtin_candidates();
  source.set_character_time(p.timing.character_time);
  CheckedRun run(p, channels);
  // Batches as `read` takes them (its read-ahead thread only regroups them into chunks).
  std::vector<ByteEvent> batch;
  while (source.next_batch(batch)) {
    for (const Anomaly& a : source.take_findings()) run.report(a);
    run.push_batch(batch);
  }
  run.finish();
  (void)source.notes();
  (void)source.error();
}

}  // namespace drivetap::fuzz
