// Display filters (-Y): parse errors with their column, precedence, each operator, fields with
// several values, strings, contains and sets, findings, the names' needs, an added name source,
// the tree of a filter's ids alone (docs/reference.md "Display filters").
#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <string>
#include <vector>

#include "core/protocol.hpp"
#include "core/protocol_desc.hpp"
#include "filter/display_filter.hpp"
#include "generate/traffic.hpp"
#include "pipeline/pipeline.hpp"
#include "sinks/sink.hpp"

using namespace drivetap;

namespace {

// The first listed descriptor of `type`: the tests name fields generically, as the filter does.
const FieldDesc* listed(FieldType type) {
  for (const FieldDesc* d : all_field_descriptors())
    if (d->type == type) return d;
  return nullptr;
}

struct Record {
  ChannelTable channels;
  Message m;
  Record() {
    m.frame.channel = channels.intern("bus");
    m.frame.number = 7;
    m.address = 2;
    m.function = 3;
    m.direction = Direction::request;
    m.protocol = Protocol(registered_protocols().front());
    m.bytes = {0x02, 0x03, 0x00, 0x10};
    m.checksum.verdict = ChecksumVerdict::bad;
  }
  [[nodiscard]] RecordView view() const {
    RecordView r;
    r.message = &m;
    r.channels = &channels;
    r.findings = m.anomalies;
    return r;
  }
};

bool passes(const std::string& filter, const Record& record) {
  std::string error;
  const std::optional<DisplayFilter> f = DisplayFilter::compile(filter, &error);
  EXPECT_TRUE(f.has_value()) << filter << ": " << error;
  return f && f->matches(record.view());
}

std::string error_of(const std::string& filter) {
  std::string error;
  EXPECT_FALSE(DisplayFilter::compile(filter, &error).has_value()) << filter;
  return error;
}

}  // namespace

TEST(DisplayFilter, ParseErrorsSayWhereWithTheFilter) {
  EXPECT_EQ(error_of("addr == && x"),
            "expected a value after '==', found '&&' at column 9: addr == && x");
  EXPECT_EQ(error_of("addr =="), "expected a value after '==', found the end at column 8: addr ==");
  EXPECT_NE(error_of("(addr == 1").find("expected ')' for the '(' of column 1"), std::string::npos);
  EXPECT_NE(error_of("(addr == 1").find("at column 11"), std::string::npos);
  EXPECT_NE(error_of("nosuch == 1").find("unknown field 'nosuch'"), std::string::npos);
  EXPECT_NE(error_of("addr = 1").find("at column 6"), std::string::npos);
  EXPECT_NE(error_of("addr == 1 &").find("at column 11"), std::string::npos);
  EXPECT_NE(error_of("addr in {1 2").find("at column 13"), std::string::npos);
  EXPECT_NE(error_of("addr in {}").find("at column 9"), std::string::npos);
  EXPECT_NE(error_of("summary contains 3").find("at column 18"), std::string::npos);
  EXPECT_NE(error_of("addr == 1)").find("unexpected ')' at column 10"), std::string::npos);
  EXPECT_NE(error_of("\"open").find("unterminated string at column 1"), std::string::npos);
  EXPECT_NE(error_of("addr == 0xZZ").find("at column 9"), std::string::npos);
  EXPECT_NE(error_of("addr == 12ab").find("bad number at column 9"), std::string::npos);
  EXPECT_NE(error_of("addr in {\"a\"..3}").find("at column 13"), std::string::npos);
  EXPECT_NE(error_of("addr matches \"x\"").find("not supported"), std::string::npos);
  EXPECT_NE(error_of("&& addr").find("expected a field name, found '&&' at column 1"),
            std::string::npos);
  EXPECT_NE(error_of("addr not 3").find("expected 'in' after 'not'"), std::string::npos);
}

// Hostile filters (issue 54): nesting is bounded with the column where it goes too deep; a long
// chain of && or || is evaluated without recursion; a literal past 64 bits is refused, not read
// as 0.
TEST(DisplayFilter, NestingDeeperThan256IsRefusedWithItsColumn) {
  const Record r;  // addr 2, fc 3
  EXPECT_TRUE(passes(std::string(256, '(') + "addr == 2" + std::string(256, ')'), r));
  EXPECT_EQ(error_of(std::string(10700, '(') + "addr == 2"),
            "parentheses and '!' nest more than 256 deep at column 257: " +
                std::string(10700, '(') + "addr == 2");
  EXPECT_TRUE(passes(std::string(256, '!') + "addr == 2", r));
  EXPECT_NE(error_of(std::string(130000, '!') + "addr == 2")
                .find("parentheses and '!' nest more than 256 deep at column 257: "),
            std::string::npos);
  EXPECT_NE(error_of("!(" + std::string(255, '(') + "addr == 2").find("at column 257"),
            std::string::npos);
}

TEST(DisplayFilter, LongChainsOfAndAndOrKeepTheirOrderAndMeaning) {
  const Record r;  // addr 2, fc 3
  std::string any = "addr == 9";
  std::string all = "addr == 2";
  for (int i = 0; i < 200000; ++i) {
    any += " || fc == 9";
    all += " && fc == 3";
  }
  EXPECT_FALSE(passes(any, r));
  EXPECT_TRUE(passes(any + " || addr == 2", r));
  EXPECT_TRUE(passes(all, r));
  EXPECT_FALSE(passes(all + " && fc == 4", r));
  EXPECT_TRUE(passes("addr == 9 || addr == 2 && fc == 3 || fc == 7", r));
  EXPECT_FALSE(passes("addr == 2 && fc == 9 || addr == 9 && fc == 3", r));
}

TEST(DisplayFilter, LiteralsPast64BitsAreRefusedWithTheirColumn) {
  const Record r;  // addr 2, fc 3
  EXPECT_EQ(error_of("n < " + std::string(309, '9')),
            "number out of range (a value has at most 64 bits: 18446744073709551615) at column "
            "5: n < " +
                std::string(309, '9'));
  EXPECT_NE(error_of("addr == 18446744073709551616").find("out of range"), std::string::npos);
  EXPECT_NE(error_of("addr == -18446744073709551616").find("out of range (a value"),
            std::string::npos);
  EXPECT_NE(error_of("addr == 0x10000000000000000").find("number out of range"), std::string::npos);
  EXPECT_TRUE(passes("addr < 18446744073709551615", r));
  EXPECT_TRUE(passes("addr > -18446744073709551615.5", r));
}

TEST(DisplayFilter, AndBindsTighterThanOrAndNotTighterThanBoth) {
  const Record r;  // addr 2, fc 3
  EXPECT_TRUE(passes("addr == 2 || addr == 9 && fc == 9", r));
  EXPECT_FALSE(passes("(addr == 2 || addr == 9) && fc == 9", r));
  EXPECT_TRUE(passes("fc == 9 && addr == 9 || addr == 2", r));
  EXPECT_FALSE(passes("!addr == 2 && fc == 3", r));
  EXPECT_TRUE(passes("!(addr == 2 && fc == 9)", r));
  EXPECT_TRUE(passes("not not addr == 2", r));
  EXPECT_TRUE(passes("addr == 1 or addr == 2 and fc == 3", r));
}

TEST(DisplayFilter, EachComparisonInSymbolsAndWords) {
  const Record r;
  EXPECT_TRUE(passes("addr == 2", r));
  EXPECT_TRUE(passes("addr eq 2", r));
  EXPECT_FALSE(passes("addr != 2", r));
  EXPECT_TRUE(passes("addr ne 3", r));
  EXPECT_TRUE(passes("addr < 3", r));
  EXPECT_TRUE(passes("addr lt 3", r));
  EXPECT_FALSE(passes("addr < 2", r));
  EXPECT_TRUE(passes("addr <= 2", r));
  EXPECT_TRUE(passes("addr le 2", r));
  EXPECT_TRUE(passes("addr > 1", r));
  EXPECT_TRUE(passes("addr gt 1", r));
  EXPECT_TRUE(passes("addr >= 2", r));
  EXPECT_TRUE(passes("addr ge 2", r));
  EXPECT_FALSE(passes("addr >= 2.5", r));
  EXPECT_TRUE(passes("fc == 0x03", r));
  EXPECT_TRUE(passes("addr > -1", r));
  EXPECT_TRUE(passes("n == 7", r));
  // A value of another type never compares: a string to a number, a number to a string.
  EXPECT_FALSE(passes("addr == \"2\"", r));
  EXPECT_FALSE(passes("dir == 1", r));
}

TEST(DisplayFilter, CloseNamesHowTheFrameEndedAsJsonDoes) {
  Record r;
  EXPECT_TRUE(passes("close == \"silence\"", r));
  r.m.frame.close = FrameClose::content;
  EXPECT_TRUE(passes("close == content", r));
  EXPECT_FALSE(passes("close == silence", r));
  r.m.frame.close = FrameClose::end_of_input;
  EXPECT_TRUE(passes("close == \"end_of_input\"", r));
}

TEST(DisplayFilter, AbsentFieldsMatchNoComparisonAndTestExistence) {
  Record r;
  r.m.address = -1;  // JSON null
  EXPECT_FALSE(passes("addr", r));
  EXPECT_FALSE(passes("addr == 2", r));
  EXPECT_FALSE(passes("addr != 2", r));  // as Wireshark: no value, no comparison holds
  EXPECT_TRUE(passes("!addr", r));
  EXPECT_TRUE(passes("fc", r));
  EXPECT_FALSE(passes("latency_ms", r));
  EXPECT_FALSE(passes("exception", r));
  r.m.is_exception = true;
  r.m.exception_code = 2;
  EXPECT_TRUE(passes("exception == 2", r));
}

TEST(DisplayFilter, StringsContainsAndBareWords) {
  const Record r;
  EXPECT_TRUE(passes("dir == \"request\"", r));
  EXPECT_TRUE(passes("dir == request", r));
  EXPECT_TRUE(passes("dir != response", r));
  EXPECT_TRUE(passes("checksum == bad", r));
  EXPECT_TRUE(passes("hex == \"02030010\"", r));
  EXPECT_TRUE(passes("hex contains \"0300\"", r));
  EXPECT_FALSE(passes("hex contains \"0301\"", r));
  EXPECT_TRUE(passes("channel == \"bus\"", r));
  EXPECT_TRUE(passes("type == frame", r));
  EXPECT_TRUE(passes("dir < \"s\"", r));  // ordered as strings
  EXPECT_TRUE(passes("protocol == \"" + std::string(protocol_id(r.m.protocol)) + "\"", r));
  EXPECT_TRUE(passes("dir == \"req\\x75est\"", r));  // escapes
}

TEST(DisplayFilter, SetsAndRanges) {
  const Record r;
  EXPECT_TRUE(passes("addr in {1 2 3}", r));
  EXPECT_TRUE(passes("addr in {1, 2, 3}", r));
  EXPECT_FALSE(passes("addr in {1 3}", r));
  EXPECT_TRUE(passes("addr in {5 1..2}", r));
  EXPECT_FALSE(passes("addr in {3..5}", r));
  EXPECT_TRUE(passes("addr not in {3..5}", r));
  EXPECT_TRUE(passes("dir in {response request}", r));
  EXPECT_TRUE(passes("fc in {0x01..0x04}", r));
  // Sorted once: repeats, overlapping ranges merged, a range backwards holding nothing, range ends
  // inclusive, numbers and strings apart.
  EXPECT_TRUE(passes("addr in {9 2 2 9}", r));
  EXPECT_TRUE(passes("addr in {0..1 1..2}", r));
  EXPECT_TRUE(passes("addr in {-5..0 1.5..3 2..2}", r));
  EXPECT_FALSE(passes("addr in {3..1}", r));
  EXPECT_TRUE(passes("addr in {3..1 2}", r));
  EXPECT_TRUE(passes("addr in {2..2}", r));
  EXPECT_FALSE(passes("addr in {2.5..9 0..1.5}", r));
  EXPECT_FALSE(passes("addr in {\"2\"}", r));
  EXPECT_FALSE(passes("dir in {2 0..9}", r));
  EXPECT_TRUE(passes("dir in {zzz request aaa}", r));
  std::string big = "addr in {";
  for (int k = 20000; k > 2; --k) big += std::to_string(k) + " ";
  EXPECT_FALSE(passes(big + "}", r));
  EXPECT_TRUE(passes(big + "2}", r));
  EXPECT_TRUE(passes(big + "0..2}", r));
}

TEST(DisplayFilter, AFieldWithSeveralValuesMatchesWhenAnyDoes) {
  const FieldDesc* number = listed(FieldType::uint);
  ASSERT_NE(number, nullptr);
  const std::string id(number->id);
  Record r;
  for (const int v : {3, 5000, 7}) {
    FieldNode& n = r.m.fields.emplace_back();
    n.desc = number;
    n.value = v;
  }
  EXPECT_TRUE(passes(id, r));
  EXPECT_TRUE(passes(id + " == 5000", r));
  EXPECT_TRUE(passes(id + " == 7", r));
  EXPECT_FALSE(passes(id + " == 4", r));
  EXPECT_FALSE(passes(id + " != 5000", r));  // Wireshark's !=: none is equal
  EXPECT_TRUE(passes(id + " != 4", r));
  EXPECT_TRUE(passes(id + " > 4000", r));
  EXPECT_TRUE(passes(id + " < 4", r));
  EXPECT_FALSE(passes(id + " > 5000", r));
  EXPECT_TRUE(passes(id + " in {1 2 7}", r));
  EXPECT_TRUE(passes(id + " in {4000..6000}", r));
}

TEST(DisplayFilter, TextAndBytesFieldsAreStrings) {
  const FieldDesc* text = listed(FieldType::text);
  const FieldDesc* bytes = listed(FieldType::bytes);
  ASSERT_NE(text, nullptr);
  ASSERT_NE(bytes, nullptr);
  Record r;
  FieldNode& t = r.m.fields.emplace_back();
  t.desc = text;
  r.m.fields.set_text(t, "motor running");
  FieldNode& b = r.m.fields.emplace_back();
  b.desc = bytes;
  b.offset = 1;
  b.length = 2;
  EXPECT_TRUE(passes(std::string(text->id) + " contains \"running\"", r));
  EXPECT_TRUE(passes(std::string(bytes->id) + " == \"0300\"", r));
  EXPECT_FALSE(passes(std::string(bytes->id) + " == 0x0300", r));
}

TEST(DisplayFilter, FindingsByKindTypedIdAndTheFindingField) {
  Record r;
  EXPECT_FALSE(passes("checksum_bad", r));
  EXPECT_FALSE(passes("finding", r));
  r.m.anomalies.push_back({AnomalyKind::checksum_bad, 0, 0, 7, "CRC on wire 80 48"});
  const FindingDesc* typed = nullptr;
  for (const ProtocolDesc* p : registered_protocols())
    for (const FindingDesc* d : p->findings)
      if (!typed && !finding_known_after_frame(d->kind)) typed = d;
  ASSERT_NE(typed, nullptr);
  Anomaly a{typed->kind, 0, 0, 7, "typed"};
  a.finding = typed;
  r.m.anomalies.push_back(a);
  EXPECT_TRUE(passes("checksum_bad", r));
  EXPECT_TRUE(passes("addr == 2 && checksum_bad", r));
  EXPECT_TRUE(passes("checksum_bad contains \"80 48\"", r));  // its detail
  EXPECT_TRUE(passes("finding == \"checksum_bad\"", r));
  EXPECT_TRUE(passes(std::string(typed->id), r));
  EXPECT_TRUE(passes("finding == \"" + std::string(typed->id) + "\"", r));
  EXPECT_TRUE(passes("finding == \"" + std::string(anomaly_id(typed->kind)) + "\"", r));
  EXPECT_FALSE(passes("finding == \"uart_break\"", r));
  EXPECT_FALSE(passes("timing_rule", r));
}

TEST(DisplayFilter, ALateFindingIsJudgedOnItsOwnRecord) {
  std::string error;
  const auto plain = DisplayFilter::compile("addr == 2 || checksum_bad", &error);
  ASSERT_TRUE(plain);
  EXPECT_FALSE(plain->names_late_findings());
  const auto late = DisplayFilter::compile("unanswered_request && addr == 2 && fc == 3", &error);
  ASSERT_TRUE(late) << error;
  EXPECT_TRUE(late->names_late_findings());
  // Never a frame's: the frame is judged before the finding is known.
  const Record r;  // addr 2, fc 3
  EXPECT_FALSE(late->matches(r.view()));
  // The finding's own record: its n, t, channel, and its frame's protocol, addr, fc.
  const RecordViews views(r.channels, 0, true);
  const LateFindingFrame frame = late_finding_frame_of(r.view());
  EXPECT_EQ(frame.number, 7u);
  const Anomaly timeout{AnomalyKind::unanswered_request, 1'500'000'000, r.m.frame.channel, 7,
                        "request #7 to address 2 function 03: no reply"};
  EXPECT_TRUE(late->matches(views.of(timeout, frame)));
  const auto passes_late = [&](const std::string& text, const Anomaly& a) {
    const auto f = DisplayFilter::compile(text, &error);
    EXPECT_TRUE(f) << text << ": " << error;
    return f && f->matches(views.of(a, frame));
  };
  EXPECT_TRUE(passes_late("type == \"anomaly\" && n == 7 && t == 1.5 && channel == bus", timeout));
  EXPECT_TRUE(passes_late("unanswered_request contains \"no reply\"", timeout));
  EXPECT_TRUE(passes_late("finding == \"unanswered_request\"", timeout));
  EXPECT_FALSE(passes_late("unanswered_request && addr == 3", timeout));
  EXPECT_FALSE(passes_late("unsolicited_response", timeout));
  EXPECT_FALSE(passes_late("dir || checksum || hex", timeout));  // not the frame's other keys
  // A finding of another frame than the one noted has no frame keys.
  const Anomaly split{AnomalyKind::packet_split_frame, 0, r.m.frame.channel, 8, "frame #8"};
  EXPECT_TRUE(passes_late("packet_split_frame && n == 8", split));
  EXPECT_FALSE(passes_late("packet_split_frame && addr", split));
}

// Whether every telegram is decoded for the filter (--stats then judges on a thread of its own):
// what its first test reads. A test after a head key's reads only the telegrams the key lets by;
// a finding's text or typed id only those whose head has its kind.
TEST(DisplayFilter, TheFirstTestSaysWhetherEveryTelegramIsDecoded) {
  const std::pair<const char*, bool> rows[] = {
      {"summary contains \"Read\"", true},
      {"summary contains \"Read\" && addr == 2", true},
      {"addr == 2 && summary contains \"Read\"", false},
      {"!(modbus.word_cnt > 4) || addr == 1", true},
      {"(drive || addr == 1) && fc == 3", true},
      {"checksum_stated == \"0A84\"", true},
      {"mbrtu.unit_id == 2 && modbus.func_code == 3", false},
      {"mbrtu.intra_frame_gap", false},
      {"mbrtu.intra_frame_gap contains \"byte\"", false},
      {"finding == \"modbus.extra_bytes\"", false},
  };
  for (const auto& [text, decodes] : rows) {
    std::string error;
    const std::optional<DisplayFilter> f = DisplayFilter::compile(text, &error);
    ASSERT_TRUE(f.has_value()) << text << ": " << error;
    EXPECT_EQ(f->first_test_decodes(), decodes) << text;
  }
}

TEST(DisplayFilter, NeedsFollowTheNamesUsed) {
  struct Row {
    const char* filter;
    bool detail, tree, message, telegram_tree;  // RecordFieldNeeds the filter must fold
    const char* why;
  };
  const Row rows[] = {
      {"addr == 2 && checksum_bad && latency_ms > 1", false, false, false, false,
       "judged on a telegram's head"},
      {"summary contains \"x\" || drive", true, false, true, false, "the texts, no tree"},
      {"modbus.word_cnt == 1", false, true, false, true,
       "the tree without the texts (info line, drive annotation) no one reads: a telegram judged "
       "by its head is decoded for its tree alone"},
      {"mbrtu.unit_id == 2 && modbus.func_code == 3", false, true, false, false,
       "tree ids the head holds (the protocol descriptor's head fields) are judged on the head; "
       "the tree is read of the telegrams decoded anyway"},
      {"mbrtu.unit_id == 2 && mbrtu.crc16 == 1", false, true, false, true, "one id no head holds"},
      {"modbus.word_cnt == 1 && summary contains \"x\"", true, true, true, true,
       "the tree and the Message's texts"},
      {"checksum_bad && !malformed", false, false, false, false,
       "a finding's presence is the head's"},
      {"checksum_bad contains \"CRC\"", false, false, true, false,
       "a finding's text, the Message's"},
      {"finding == \"checksum_bad\" || checksum_stated", false, false, true, false,
       "typed ids and the stated checksum are the Message's"},
  };
  for (const Row& row : rows) {
    SCOPED_TRACE(std::string(row.filter) + ": " + row.why);
    std::string error;
    auto filter = DisplayFilter::compile(row.filter, &error);
    ASSERT_TRUE(filter) << error;
    EXPECT_EQ(filter->needs().detail, row.detail);
    EXPECT_EQ(filter->needs().tree, row.tree);
    EXPECT_EQ(filter->needs().message, row.message);
    EXPECT_EQ(filter->needs().telegram_tree, row.telegram_tree);
  }
}

namespace {
// A name source as the drive layer adds one: "test.drive.speed" with the frame's address x 10.
class SpeedSource final : public RecordFieldSource {
 public:
  std::optional<int> resolve(std::string_view name) const override {
    if (name == "test.drive.speed") return 0;
    return std::nullopt;
  }
  RecordFieldNeeds needs(int) const override { return {}; }
  bool values(int, const RecordView& r, std::string& scratch, ValueVisitor& visit) const override {
    scratch = std::to_string(r.message->address * 10);
    return visit.visit({true, r.message->address * 10.0, scratch});
  }
};
}  // namespace

TEST(DisplayFilter, AnAddedSourceResolvesItsNames) {
  EXPECT_FALSE(resolve_record_field("test.drive.speed").has_value());
  add_record_field_source(std::make_unique<SpeedSource>());
  const Record r;
  EXPECT_TRUE(passes("test.drive.speed == 20", r));
  EXPECT_TRUE(passes("test.drive.speed in {10..30} && addr == 2", r));
}

TEST(DisplayFilter, NoiseRecordsHaveTheirKeysAndFindings) {
  ChannelTable channels;
  Frame noise;
  noise.channel = channels.intern("bus");
  noise.number = 4;
  noise.kind = FrameKind::noise;
  const std::vector<Anomaly> findings{{AnomalyKind::noise, 0, 0, 4, "1 byte outside any frame"}};
  RecordView r;
  r.noise = &noise;
  r.channels = &channels;
  r.findings = findings;
  std::string error;
  for (const char* yes : {"noise", "n == 4", "type == noise", "finding == \"noise\"", "!addr"}) {
    auto f = DisplayFilter::compile(yes, &error);
    ASSERT_TRUE(f) << error;
    EXPECT_TRUE(f->matches(r)) << yes;
  }
  for (const char* no : {"addr", "dir", "checksum", "summary contains \"x\""}) {
    auto f = DisplayFilter::compile(no, &error);
    ASSERT_TRUE(f) << error;
    EXPECT_FALSE(f->matches(r)) << no;
  }
}

namespace {

// Every frame of the generator's mixed bus (four protocols, errors, noise), as the pipeline hands
// it over decoded in full, with what it was dissected from.
struct DissectedFrames final : Sink {
  struct Input {
    Frame frame;
    Direction direction;
    Protocol protocol;
  };
  std::vector<Input> inputs;
  void on_frame(const Message& m) override { inputs.push_back({m.frame, m.direction, m.protocol}); }
  void on_noise(const Frame&) override {}
  bool flush() override { return true; }
};

// `full`'s nodes of the ids in `ids`, in order, their texts with them.
FieldTree kept_of(const FieldTree& full, const FieldIdSet& ids) {
  FieldTree out;
  for (const FieldNode& n : full)
    if (ids.contains(*n.desc)) out.push_back_from(full, n);
  return out;
}

}  // namespace

TEST(DisplayFilter, ATreeOfSomeIdsHoldsTheFullTreesNodesOfThem) {
  // A filter's own decode (TelegramTree) keeps only the ids it reads: for every telegram of every
  // protocol and each of its protocol's ids alone, and with the next id of its layer (a group
  // with a child, two siblings), the kept tree is the full tree's nodes of those ids: values,
  // spans (a group's over its children, kept or not), depths and texts.
  DissectedFrames sink;
  ChannelTable channels;
  generate::Generator gen(generate::Options{3000, 7, generate::Mix::all});
  PipelineOptions options;
  options.serial = generate::Generator::serial();
  options.timing = FramingTiming::from(options.serial);
  Pipeline pipeline(options, channels, sink);
  std::vector<int> channel_of(gen.links().size(), -1);
  generate::Record r;
  std::vector<ByteEvent> events;
  while (gen.next(r)) {
    if (channel_of[r.link] < 0) channel_of[r.link] = channels.intern(gen.links()[r.link].channel);
    for (std::size_t i = 0; i < r.bytes.size(); ++i)
      events.push_back({r.start + static_cast<TimeNs>(i) * options.timing.character_time,
                        r.bytes[i], r.flags[i], static_cast<ChannelId>(channel_of[r.link]), 0});
  }
  pipeline.push_batch(events);
  pipeline.finish();
  ASSERT_GT(sink.inputs.size(), 2000u);

  std::set<const FieldDesc*> seen;
  std::size_t compared = 0;
  Message full, kept, alone;
  for (const DissectedFrames::Input& in : sink.inputs) {
    const ProtocolDecoder* decoder = decoder_for(in.protocol);
    ASSERT_NE(decoder, nullptr);
    decoder->dissect_into(full, Frame(in.frame), in.direction, options.timing);
    for (const FieldProtocol* layer : in.protocol.desc()->field_protocols) {
      for (std::size_t i = 0; i < layer->fields.size(); ++i) {
        for (const std::size_t with : {i, i + 1}) {
          if (with >= layer->fields.size()) continue;
          FieldIdSet ids;
          ids.add(*layer->fields[i]);
          ids.add(*layer->fields[with]);
          kept.fields.keep_only(&ids);
          kept.info_text = false;
          decoder->dissect_into(kept, Frame(in.frame), in.direction, options.timing);
          kept.fields.keep_only(nullptr);
          const FieldTree want = kept_of(full.fields, ids);
          ASSERT_TRUE(kept.fields == want)
              << "frame " << in.frame.number << ", " << layer->fields[i]->id << " with "
              << layer->fields[with]->id << ": " << kept.fields.size() << " nodes, the full tree "
              << want.size();
          // The same to DissectDepth::fields, the tree alone (what TelegramTree reads), with
          // the bytes and encoding a node's value is read from.
          Frame frame(in.frame);
          TelegramView view;
          view.frame = &frame;
          alone.fields.keep_only(&ids);
          decoder->dissect(view, in.direction, options.timing, {}, DissectDepth::fields, alone,
                           nullptr);
          alone.fields.keep_only(nullptr);
          ASSERT_TRUE(alone.fields == want)
              << "frame " << in.frame.number << " to DissectDepth::fields, " << layer->fields[i]->id
              << " with " << layer->fields[with]->id << ": " << alone.fields.size()
              << " nodes, the full tree " << want.size();
          ASSERT_EQ(alone.bytes, full.bytes) << "frame " << in.frame.number;
          ASSERT_EQ(alone.text_encoded, full.text_encoded) << "frame " << in.frame.number;
          if (!want.empty()) seen.insert(layer->fields[i]->key());
          ++compared;
        }
      }
    }
  }
  // The ids the generator's telegrams carry (43 of the four protocols') were there to compare.
  EXPECT_GT(compared, 50000u);
  EXPECT_GE(seen.size(), 40u);
}

TEST(DisplayFilter, ATreeOfSomeIdsStretchesAKeptGroupOverItsDroppedChildren) {
  FieldDesc group{.id = "t.group", .name = "group", .type = FieldType::group};
  FieldDesc child{.id = "t.child", .name = "child"};
  FieldDesc other{.id = "t.other", .name = "other"};
  const auto build = [&](FieldTree& tree) {
    FieldTreeBuilder b(tree);
    b.add(other, 0, 1, 1);
    b.open(group, 1, 1);
    b.add(child, 1, 2, 2);
    b.open(group, 3, 0);
    b.add_text(child, 3, 4, "deep", 3);
    b.close();
    b.close();
    b.add(other, 9, 1, 4);
  };
  FieldTree full;
  build(full);
  ASSERT_EQ(full.size(), 6u);
  EXPECT_EQ(full[1].length, 6u);  // 1..7
  for (const FieldDesc* only : {&group, &child, &other}) {
    FieldIdSet ids;
    ids.add(*only);
    FieldTree kept;
    kept.keep_only(&ids);
    build(kept);
    EXPECT_TRUE(kept == kept_of(full, ids)) << only->id;
    EXPECT_EQ(kept.size(), 2u) << only->id;
  }
}
