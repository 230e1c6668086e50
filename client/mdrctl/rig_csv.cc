#include "rig_csv.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <regex>
#include <system_error>
#include <utility>
#include <vector>

namespace mdrctl {
namespace {

struct UnitName {
  const char* name;
  double factor;
};
constexpr std::array<UnitName, 5> kDisplacementUnits{
    {{"m", 1}, {"mm", 1e-3}, {"um", 1e-6}, {"µm", 1e-6}, {"nm", 1e-9}}};
constexpr std::array<UnitName, 3> kForceUnits{{{"N", 1}, {"kN", 1e3}, {"mN", 1e-3}}};
constexpr std::array<UnitName, 4> kTimeUnits{{{"s", 1}, {"ms", 1e-3}, {"us", 1e-6}, {"µs", 1e-6}}};
constexpr std::array<UnitName, 5> kTwistUnits{
    {{"rad", 1}, {"mrad", 1e-3}, {"urad", 1e-6}, {"µrad", 1e-6}, {"deg", std::numbers::pi / 180}}};
constexpr std::array<UnitName, 3> kMomentUnits{{{"N m", 1}, {"N mm", 1e-3}, {"mN m", 1e-3}}};

template <std::size_t N>
mdr::Result<double> Lookup(const std::array<UnitName, N>& units, const std::string& unit,
                           const std::string& field) {
  std::string names;
  for (const UnitName& u : units) {
    if (unit == u.name) return u.factor;
    names += (names.empty() ? "" : ", ") + std::string(u.name);
  }
  return mdr::InvalidArgument(field, "must be one of " + names + ", got " + Printable(unit));
}

std::string_view Trim(std::string_view text) {
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!text.empty() && space(text.front())) text.remove_prefix(1);
  while (!text.empty() && space(text.back())) text.remove_suffix(1);
  return text;
}

// A cell without its surrounding whitespace and double quotes (spreadsheets and pandas may quote
// every cell).
std::string_view Unquoted(std::string_view cell) {
  cell = Trim(cell);
  if (cell.size() >= 2 && cell.front() == '"' && cell.back() == '"') {
    cell = Trim(cell.substr(1, cell.size() - 2));
  }
  return cell;
}

std::string HeaderName(std::string_view cell) { return std::string(Unquoted(cell)); }

std::vector<std::string_view> Split(std::string_view line, char delimiter) {
  std::vector<std::string_view> cells;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= line.size(); ++i) {
    if (i == line.size() || line[i] == delimiter) {
      cells.push_back(line.substr(start, i - start));
      start = i + 1;
    }
  }
  return cells;
}

bool Skipped(std::string_view line) {
  const std::string_view trimmed = Trim(line);
  return trimmed.empty() || trimmed.front() == '#';
}

// A file's lines, one at a time, without their line ends (and without a UTF-8 byte order mark
// at the start of the file): holds one line and one block of the file, so that a line past
// max_line_bytes is refused having read no more than that.
class LineReader {
 public:
  LineReader(std::istream& in, std::size_t max_line_bytes)
      : in_(in), max_line_bytes_(max_line_bytes) {}

  // kUnterminated: the file ends inside a line (its bytes after the last '\n', even only a
  // '\r'), which is not read: a file cut short would end in a cut cell ("20.0" as "2").
  enum class Read { kLine, kEnd, kTooLong, kFailed, kUnterminated };

  // The next line into *line; number() is then its 1-based number in the file.
  Read Next(std::string* line) {
    line->clear();
    while (true) {
      if (at_ == filled_ && !Fill()) {
        if (in_.bad()) return Read::kFailed;
        if (line->empty()) return Read::kEnd;
        ++number_;
        return Read::kUnterminated;
      }
      const char* begin = block_.data() + at_;
      const char* end = block_.data() + filled_;
      const char* newline = std::find(begin, end, '\n');
      const std::size_t take = static_cast<std::size_t>(newline - begin);
      if (line->size() + take > max_line_bytes_ + 1) {  // + 1: a '\r' before the '\n'
        ++number_;
        return Read::kTooLong;
      }
      line->append(begin, take);
      at_ += take;
      if (newline != end) {
        ++at_;
        return Finish(line);
      }
    }
  }
  std::size_t number() const { return number_; }

 private:
  // Reads the next block; false at the end of the file. The first block skips a byte order mark.
  bool Fill() {
    if (!in_) return false;
    in_.read(block_.data(), static_cast<std::streamsize>(block_.size()));
    filled_ = static_cast<std::size_t>(in_.gcount());
    at_ = 0;
    if (first_block_) {
      first_block_ = false;
      if (std::string_view(block_.data(), filled_).starts_with("\xEF\xBB\xBF")) at_ = 3;
    }
    return filled_ > 0;
  }
  Read Finish(std::string* line) {
    ++number_;
    if (line->ends_with('\r')) line->pop_back();
    return line->size() > max_line_bytes_ ? Read::kTooLong : Read::kLine;
  }

  std::istream& in_;
  std::size_t max_line_bytes_;
  std::vector<char> block_ = std::vector<char>(std::size_t{1} << 16);
  std::size_t at_ = 0, filled_ = 0, number_ = 0;
  bool first_block_ = true;
};

// The separator the header uses: the only one of ',', ';' and tab it holds (',' for none).
mdr::Result<char> Delimiter(std::string_view header, const std::string& where) {
  std::string found;
  for (char c : {',', ';', '\t'}) {
    if (header.find(c) != std::string_view::npos) found += c;
  }
  if (found.size() > 1) {
    return mdr::InvalidArgument(where, "the header mixes the separators " + Printable(found) +
                                           ": use one of ',', ';' or tab");
  }
  return found.empty() ? ',' : found.front();
}

struct Selected {
  SelectedColumn column;
  std::size_t cell = 0;
};

// The header's cell named `name`, once.
mdr::Result<std::size_t> FindColumn(const std::vector<std::string>& header, const std::string& name,
                                    const std::string& where) {
  std::vector<std::size_t> at;
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) at.push_back(i);
  }
  if (at.size() == 1) return at.front();
  if (at.size() > 1) {
    return mdr::InvalidArgument(
        where, "column " + Printable(name) + " appears more than once in the header");
  }
  std::string names;
  for (std::size_t i = 0; i < header.size() && i < 32; ++i) {
    names += (i ? ", " : "") + Printable(header[i]);
  }
  if (header.size() > 32) names += ", ...";
  return mdr::InvalidArgument(
      where, "no column " + Printable(name) + " in the header; its columns are " + names);
}

// The header's cells as names, checked for the selected columns.
mdr::Status FindColumns(const std::vector<std::string>& header, const std::string& where,
                        std::vector<Selected>* selected) {
  for (Selected& column : *selected) {
    auto cell = FindColumn(header, column.column.name, where);
    if (!cell.ok()) return cell.status();
    column.cell = *cell;
  }
  return mdr::OkStatus();
}

// The samples and lines of one run of `file`.
RigData RunOf(const RigData& file, const RigRun& run) {
  RigData piece;
  piece.path = file.path;
  piece.format = file.format;
  piece.synthetic = file.synthetic;
  piece.run = run.id;
  const auto begin = static_cast<int>(run.first), end = static_cast<int>(run.first + run.count);
  const auto copy = [&](const google::protobuf::RepeatedField<double>& from,
                        google::protobuf::RepeatedField<double>* to) {
    if (from.empty()) return;
    to->Add(from.begin() + begin, from.begin() + end);
  };
  copy(file.samples.displacement(), piece.samples.mutable_displacement());
  copy(file.samples.tangential_force(), piece.samples.mutable_tangential_force());
  copy(file.samples.twist(), piece.samples.mutable_twist());
  copy(file.samples.twisting_moment(), piece.samples.mutable_twisting_moment());
  copy(file.samples.normal_force(), piece.samples.mutable_normal_force());
  copy(file.samples.time(), piece.samples.mutable_time());
  piece.lines.assign(file.lines.begin() + begin, file.lines.begin() + end);
  return piece;
}

// A cell as a finite number: C locale, a leading '+' allowed, optionally quoted. With
// decimal_comma (a file separated by ';' or tab, as spreadsheets write where the comma is the
// decimal separator) one ',' stands for the '.', in a cell without '.': "1,5e-6" is 1.5e-6, while
// "1.234,5" is refused (a thousands separator cannot be told from a decimal one).
mdr::Result<double> ParseCell(std::string_view cell, bool decimal_comma, const std::string& where,
                              const std::string& column) {
  const std::string_view text = Unquoted(cell);
  if (text.empty()) {
    return mdr::InvalidArgument(where, "column " + Printable(column) + ": the cell is empty");
  }
  std::string with_point;
  std::string_view digits = text;
  const std::size_t comma = text.find(',');
  const bool comma_is_point = decimal_comma && comma != std::string_view::npos &&
                              text.find(',', comma + 1) == std::string_view::npos &&
                              text.find('.') == std::string_view::npos;
  if (comma_is_point) {
    with_point = std::string(text);
    with_point[comma] = '.';
    digits = with_point;
  }
  if (digits.starts_with('+')) digits.remove_prefix(1);
  double value = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (error != std::errc() || end != digits.data() + digits.size() || !std::isfinite(value)) {
    const bool both = decimal_comma && comma != std::string_view::npos && !comma_is_point;
    return mdr::InvalidArgument(
        where,
        "column " + Printable(column) + ": " + Printable(text) + " is not a finite number" +
            (both ? " (a decimal comma is read only in a cell with one ',' and no '.')" : ""));
  }
  return value;
}

}  // namespace

std::string RunSplitter::Add(std::string_view id, std::size_t place, std::string_view place_name) {
  const std::size_t sample = samples_++;
  if (!runs_.empty() && runs_.back().id == id) {
    ++runs_.back().count;
    last_places_.back() = place;
    return "";
  }
  const auto [found, added] = index_.emplace(std::string(id), runs_.size());
  if (!added) {
    const std::size_t earlier = found->second;
    return "run " + Printable(id) + " appears again after run " + Printable(runs_.back().id) +
           " (its rows ended at " + std::string(place_name) + " " +
           std::to_string(last_places_[earlier]) +
           "): the rows of a run must be contiguous; interleaved runs are usually a bad export";
  }
  runs_.push_back({std::string(id), sample, 1});
  last_places_.push_back(place);
  return "";
}

std::string RunIds(const std::vector<RigRun>& runs) {
  std::string ids;
  for (std::size_t i = 0; i < runs.size() && i < 32; ++i) {
    ids += (i ? ", " : "") + Printable(runs[i].id);
  }
  if (runs.size() > 32) ids += ", ...";
  return ids.empty() ? "none" : ids;
}

std::vector<RigData> SplitRuns(const RigData& file) {
  if (file.runs.empty()) return {file};
  std::vector<RigData> runs;
  for (const RigRun& run : file.runs) runs.push_back(RunOf(file, run));
  return runs;
}

mdr::Result<RigData> SelectRun(const RigData& file, const CsvLayout& layout,
                               const std::string& id) {
  for (const RigRun& run : file.runs) {
    if (run.id == id) return RunOf(file, run);
  }
  const std::string column =
      (file.format == RigFormat::kMat ? "variable " : "column ") + Printable(layout.run_column);
  return mdr::InvalidArgument(file.path, "no run " + Printable(id) + " in " + column +
                                             "; its runs are " + RunIds(file.runs));
}

std::string Printable(std::string_view text, std::size_t limit) {
  std::string out = "\"";
  const bool cut = text.size() > limit;
  for (unsigned char c : text.substr(0, limit)) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c >= 0x7f) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02X", c);
      out += escaped;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + (cut ? "...\"" : "\"");
}

mdr::Result<double> UnitFactor(Quantity quantity, const std::string& unit,
                               const std::string& field) {
  switch (quantity) {
    case Quantity::kDisplacement:
      return Lookup(kDisplacementUnits, unit, field);
    case Quantity::kForce:
      return Lookup(kForceUnits, unit, field);
    case Quantity::kTwist:
      return Lookup(kTwistUnits, unit, field);
    case Quantity::kMoment:
      return Lookup(kMomentUnits, unit, field);
    case Quantity::kTime:
      break;
  }
  return Lookup(kTimeUnits, unit, field);
}

bool IsTorsional(const CsvLayout& layout) {
  return layout.channel == mdr::analysis::LoopChannel::kTorsional;
}

const google::protobuf::RepeatedField<double>& LoopPositions(const mdr::v1::LoopSamples& samples) {
  return samples.twist().empty() ? samples.displacement() : samples.twist();
}

const google::protobuf::RepeatedField<double>& LoopForces(const mdr::v1::LoopSamples& samples) {
  return samples.twist().empty() ? samples.tangential_force() : samples.twisting_moment();
}

std::vector<SelectedColumn> SelectColumns(const CsvLayout& layout, mdr::v1::LoopSamples* samples) {
  std::vector<SelectedColumn> columns =
      IsTorsional(layout)
          ? std::vector<SelectedColumn>{{layout.twist_column, layout.twist_unit,
                                         samples->mutable_twist()},
                                        {layout.moment_column, layout.moment_unit,
                                         samples->mutable_twisting_moment()}}
          : std::vector<SelectedColumn>{
                {layout.displacement_column, layout.displacement_unit,
                 samples->mutable_displacement()},
                {layout.force_column, layout.force_unit, samples->mutable_tangential_force()}};
  if (!layout.normal_force_column.empty()) {
    columns.push_back(
        {layout.normal_force_column, layout.force_unit, samples->mutable_normal_force()});
  }
  if (!layout.time_column.empty()) {
    columns.push_back({layout.time_column, layout.time_unit, samples->mutable_time()});
  }
  return columns;
}

mdr::Result<RigData> ReadRigFile(const std::string& path, const CsvLayout& layout,
                                 const RigFileLimits& limits) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return extension == ".mat" ? ReadRigMat(path, layout, limits) : ReadRigCsv(path, layout, limits);
}

mdr::Result<RigData> ReadRigCsv(const std::string& path, const CsvLayout& layout,
                                const RigFileLimits& limits) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    return mdr::InvalidArgument(path, "is a directory, not a CSV file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return mdr::InvalidArgument(path, "cannot open the CSV file");
  LineReader reader(in, limits.max_line_bytes);
  RigData csv;
  csv.path = path;
  const auto where = [&] { return path + ":" + std::to_string(reader.number()); };

  std::optional<std::size_t> header_line;
  char delimiter = ',';
  std::vector<std::string> header;
  std::vector<Selected> selected;
  std::optional<std::size_t> run_cell;
  RunSplitter runs;
  std::string line;
  while (true) {
    switch (reader.Next(&line)) {
      case LineReader::Read::kLine:
        break;
      case LineReader::Read::kTooLong:
        return mdr::InvalidArgument(where(), "the line is longer than " +
                                                 std::to_string(limits.max_line_bytes) +
                                                 " bytes, the most mdrctl reads in one line");
      case LineReader::Read::kFailed:
        return mdr::InvalidArgument(
            path, "cannot read the CSV file after line " + std::to_string(reader.number()));
      case LineReader::Read::kUnterminated:
        return mdr::InvalidArgument(
            where(),
            "the last line has no line end: the file may be cut short (a rig still writing "
            "it?), its last cell cut with it; if the file is complete, end its last line with a "
            "line end");
      case LineReader::Read::kEnd:
        if (!header_line) {
          return mdr::InvalidArgument(
              path, "the file is empty: no header line (only comments or blank lines)");
        }
        if (csv.lines.empty()) {
          return mdr::InvalidArgument(
              path, "no data rows after the header (line " + std::to_string(*header_line) + ")");
        }
        csv.runs = runs.Take();
        return csv;
    }
    const std::string_view trimmed = Trim(line);
    if (trimmed.starts_with("# SYNTHETIC") && !csv.synthetic) {
      csv.synthetic = Printable(trimmed.substr(2), 240);
    }
    if (Skipped(line)) continue;
    if (!header_line) {
      header_line = reader.number();
      auto found = Delimiter(line, where());
      if (!found.ok()) return found.status();
      delimiter = *found;
      for (std::string_view cell : Split(line, delimiter)) header.push_back(HeaderName(cell));
      for (const SelectedColumn& column : SelectColumns(layout, &csv.samples)) {
        selected.push_back({column});
      }
      if (auto s = FindColumns(header, where(), &selected); !s.ok()) return s;
      if (!layout.run_column.empty()) {
        auto cell = FindColumn(header, layout.run_column, where());
        if (!cell.ok()) return cell.status();
        run_cell = *cell;
      }
      continue;
    }
    if (csv.lines.size() == limits.max_samples) {
      return mdr::InvalidArgument(where(), "the file has more than " +
                                               std::to_string(limits.max_samples) +
                                               " data rows (samples), the most mdrctl reads");
    }
    const std::vector<std::string_view> cells = Split(line, delimiter);
    if (cells.size() != header.size()) {
      const std::string detail =
          cells.size() < header.size()
              ? "; column " + Printable(header[cells.size()]) + " has no cell"
              : "";
      return mdr::InvalidArgument(where(), "the row has " + std::to_string(cells.size()) +
                                               " cells, the header (line " +
                                               std::to_string(*header_line) + ") has " +
                                               std::to_string(header.size()) + detail);
    }
    for (const auto& [column, cell] : selected) {
      auto value = ParseCell(cells[cell], delimiter != ',', where(), column.name);
      if (!value.ok()) return value.status();
      column.values->Add(*value * column.factor);
    }
    if (run_cell) {
      const std::string_view id = Unquoted(cells[*run_cell]);
      const std::string refused = id.empty() ? "the cell is empty: every row needs its run's id"
                                             : runs.Add(id, reader.number(), "line");
      if (!refused.empty()) {
        return mdr::InvalidArgument(where(),
                                    "column " + Printable(layout.run_column) + ": " + refused);
      }
    }
    csv.lines.push_back(reader.number());
  }
}

mdr::Status LocateSampleError(const std::string& field, const std::string& message,
                              const RigData& csv, const CsvLayout& layout) {
  static const std::regex kSample(
      R"((?:^|\.)samples\.(displacement|tangential_force|twisting_moment|twist|normal_force|time)(?:\[([0-9]+)\])?$)");
  std::smatch match;
  if (!std::regex_search(field, match, kSample)) {
    return mdr::InvalidArgument(csv.path, field.empty() ? message : field + ": " + message);
  }
  const std::string which = match[1];
  const std::string column = which == "displacement"       ? layout.displacement_column
                             : which == "tangential_force" ? layout.force_column
                             : which == "twist"            ? layout.twist_column
                             : which == "twisting_moment"  ? layout.moment_column
                             : which == "normal_force"     ? layout.normal_force_column
                                                           : layout.time_column;
  std::optional<std::size_t> at;  // the sample's line (CSV) or element (MAT)
  if (match[2].matched) {
    const std::size_t index = std::stoull(match[2]);
    if (index < csv.lines.size()) at = csv.lines[index];
  }
  if (csv.format == RigFormat::kMat) {
    return mdr::InvalidArgument(csv.path, "variable " + Printable(column) +
                                              (at ? ", element " + std::to_string(*at) : "") +
                                              ": " + message);
  }
  const std::string where = at ? csv.path + ":" + std::to_string(*at) : csv.path;
  return mdr::InvalidArgument(where, "column " + Printable(column) + ": " + message);
}

}  // namespace mdrctl
