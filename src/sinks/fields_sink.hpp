// `-T fields`: one line per frame or noise record with the values of the fields named by -e,
// formatted as -E says, as tshark -T fields does (docs/reference.md "-T fields"). The names are
// those of the display filter (src/filter/record_fields.hpp); a field with several values prints
// them all, the first or the last (occurrence), joined by the aggregator.
#pragma once

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "filter/record_fields.hpp"
#include "sinks/line_writer.hpp"
#include "sinks/sink.hpp"
#include "sinks/time_format.hpp"

namespace drivetap {

struct FieldsOptions {
  std::vector<RecordField> fields;
  std::vector<std::string> names;  // as given
  char separator = '\t';
  char aggregator = ',';
  char quote = 0;  // 0: none
  bool header = false;
  char occurrence = 'a';  // 'f' first, 'l' last, 'a' all
  // `t` as -t shows it (the text output's time column); `clock`: the capture's, nullptr for
  // relative seconds as the JSON has them.
  TimeFormat time_format = TimeFormat::relative;
  const TimeReference* clock = nullptr;
};

// The options of `-e` names and `-E key=value` settings, or nullopt with `error` set (a line naming
// the option).
std::optional<FieldsOptions> parse_fields_options(const std::vector<std::string>& names,
                                                  const std::vector<std::string>& settings,
                                                  std::string* error);

class FieldsSink final : public FormattingSink {
 public:
  FieldsSink(std::FILE* out, FieldsOptions options, const ChannelTable& channels,
             TimeNs character_time, bool show_latency);

  void on_frame(const Message& m) override;
  void on_noise(const Frame& f) override;
  // (Anomalies, transactions: not rows; nor a summary line under the table: tshark prints none.)
  bool flush() override { return lines_.flush(); }
  [[nodiscard]] SinkNeeds needs() const override;
  LineBuffer* formatted() override { return nullptr; }
  void write_formatted(std::string_view) override {}

 private:
  void write_record(const RecordView& record, TimeNs time, TimeNs end);
  void append_value(std::string_view text);

  FieldsOptions options_;
  RecordViews views_;
  LineWriter lines_;
  std::string scratch_;
  std::string value_;
  TimeNs previous_time_ = -1;  // the previous record's, for -t d and dd
};

}  // namespace drivetap
