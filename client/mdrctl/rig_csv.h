// A test rig's samples file, read by ReadRigFile: a CSV file, or a MATLAB file (*.mat).
//
// CSV: one sample per row, columns chosen by their header names, values in stated units converted
// to SI. '#' comment lines and blank lines are skipped anywhere; the first other line is the
// header. Cells are separated by ',' (or ';' or a tab, when the header uses exactly one of the
// three). Every line ends with a line end: a last line without one is refused (the file may be cut
// short, a cell "20.0" read as "2"). Every error names the file, the line (1-based, counting every
// line of the file) and the column; text taken from the file is quoted bounded and escaped
// (Printable). The file is read a line at a time, so that any file (a log still growing,
// /dev/zero) costs bounded memory.
//
// MATLAB (rig_mat.cc): a "column" is a variable of that name, a real numeric vector, or a field
// of a 1x1 struct ("run.force"); every error names the file, the variable and the element.
//
// A file of several runs names each sample's run in a run column (CsvLayout::run_column): the
// rows of one run are contiguous, in any order of the runs; SplitRuns and SelectRun take them
// apart.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "mdr/analysis/loops.h"
#include "mdr/base/sample_limits.h"
#include "mdr/base/status.h"
#include "mdr/v1/analysis.pb.h"

namespace mdrctl {

enum class Quantity { kDisplacement, kForce, kTime, kTwist, kMoment };

// The factor from `unit` to SI: displacement m, mm, um (or µm), nm; force N, kN, mN; time s, ms,
// us (or µs); twist rad, mrad, urad (or µrad), deg; moment "N m", "N mm", "mN m". Errors name
// `field` and list the units of the quantity.
mdr::Result<double> UnitFactor(Quantity quantity, const std::string& unit,
                               const std::string& field);

// Which columns hold what, and their units (factors to SI). A record is tangential (displacement
// and tangential force) or torsional (twist and twisting moment, docs/analysis.md "Torsional
// records"): `channel` says which pair of columns is read; the other pair's names are unused.
struct CsvLayout {
  mdr::analysis::LoopChannel channel = mdr::analysis::LoopChannel::kTangential;
  std::string displacement_column = "displacement";
  std::string force_column = "tangential_force";
  std::string twist_column = "twist";
  std::string moment_column = "twisting_moment";
  std::string normal_force_column;  // empty: none
  std::string time_column;          // empty: none
  // The column of each sample's run id, in a file of several runs; empty: the file is one run.
  std::string run_column;
  // force_unit is the normal force's too (and in a torsional record only the normal force's).
  double displacement_unit = 1, force_unit = 1, time_unit = 1;
  double twist_unit = 1, moment_unit = 1;  // to rad and N m
};

bool IsTorsional(const CsvLayout& layout);

// A record's loop columns whatever its channel: the displacement or the twist, the tangential
// force or the twisting moment (a record holds one pair or the other).
const google::protobuf::RepeatedField<double>& LoopPositions(const mdr::v1::LoopSamples& samples);
const google::protobuf::RepeatedField<double>& LoopForces(const mdr::v1::LoopSamples& samples);

enum class RigFormat { kCsv, kMat };

// What a reader holds at most: a file past a bound is refused when the reader reaches it, having
// held no more than the bound (the tests lower the bounds to reach them).
struct RigFileLimits {
  // Samples: data rows of a CSV file, elements of a MAT file's variable; by default what one
  // AnalyzeLoops call takes, for the whole file (all its runs).
  std::size_t max_samples = mdr::kMaxAnalyzedSamples;
  // Bytes of one CSV line, its line end not counted.
  std::size_t max_line_bytes = std::size_t{1} << 20;
};

// One run of a file with a run column: its id as the file writes it (a CSV cell trimmed and
// unquoted; a MAT element's number: an integer in decimal, else its shortest form) and its
// samples, [first, first + count) of the file's.
struct RigRun {
  std::string id;
  std::size_t first = 0, count = 0;
};

struct RigData {
  std::string path;
  RigFormat format = RigFormat::kCsv;
  mdr::v1::LoopSamples samples;  // SI
  // The file line of every sample (a MAT file: its 1-based element in the variables).
  std::vector<std::size_t> lines;
  // The text of a "# SYNTHETIC ..." comment (bounded, escaped), if the file has one.
  std::optional<std::string> synthetic;
  // With a run column: the file's runs in the order they first appear; empty without one.
  std::vector<RigRun> runs;
  // The id of the run these samples are, when taken from such a file (SplitRuns, SelectRun).
  std::optional<std::string> run;
};

// Each run of a file read with a run column, in the order they appear, its samples and lines
// only; a file without a run column as it is.
std::vector<RigData> SplitRuns(const RigData& file);

// The run `id` of a file read with a run column (layout.run_column names it in the error). Errors:
// INVALID_ARGUMENT with the field the file's path, naming the id and the file's ids (at most 32).
mdr::Result<RigData> SelectRun(const RigData& file, const CsvLayout& layout, const std::string& id);

// The runs' ids for a message: quoted and escaped (Printable), at most 32, then "...".
std::string RunIds(const std::vector<RigRun>& runs);

// The runs of a run column, built sample by sample by both readers. A run is one contiguous block
// of samples: an id that reappears after another run is refused, because interleaved runs are
// almost always a bad export (a merge sorted by time, say), not a recording.
class RunSplitter {
 public:
  // Adds the next sample, of run `id` (not empty), at `place`, its line or element ("line",
  // "element": `place_name`). Returns "" or why the sample is refused.
  std::string Add(std::string_view id, std::size_t place, std::string_view place_name);
  std::vector<RigRun> Take() { return std::move(runs_); }

 private:
  std::vector<RigRun> runs_;
  std::vector<std::size_t> last_places_;                // of each run in runs_
  std::unordered_map<std::string, std::size_t> index_;  // id -> its run in runs_
  std::size_t samples_ = 0;
};

// A column the layout selects: its name, its factor to SI and the samples' field it fills (the
// displacement and the tangential force, or the twist and the twisting moment; then the normal
// force and the time if named).
struct SelectedColumn {
  std::string name;
  double factor;
  google::protobuf::RepeatedField<double>* values;
};
std::vector<SelectedColumn> SelectColumns(const CsvLayout& layout, mdr::v1::LoopSamples* samples);

// Reads and converts a MAT file (a name ending in ".mat", any case) or else a CSV file.
mdr::Result<RigData> ReadRigFile(const std::string& path, const CsvLayout& layout,
                                 const RigFileLimits& limits = {});

// Reads and converts the file; errors are INVALID_ARGUMENT with the field "path:line" (or "path"
// for the file as a whole).
mdr::Result<RigData> ReadRigCsv(const std::string& path, const CsvLayout& layout,
                                const RigFileLimits& limits = {});

// Reads and converts a MATLAB file of version 4, 5 (compressed or not) or 7.3 (HDF5): every
// selected variable a real numeric vector (double, single or integer; not logical, complex or
// sparse) of at most limits.max_samples finite elements, all of the same length; a file cut short,
// or whose byte counts or dimensions disagree with its contents, is refused. Errors are
// INVALID_ARGUMENT with the field "path" and name the variable (and element).
mdr::Result<RigData> ReadRigMat(const std::string& path, const CsvLayout& layout,
                                const RigFileLimits& limits = {});

// An error of the service about a sample ("samples.time[12]", "sets[2].samples.twist[12]") or a
// column ("samples.displacement") restated at the file's line and column; other errors are
// prefixed with the file.
mdr::Status LocateSampleError(const std::string& field, const std::string& message,
                              const RigData& csv, const CsvLayout& layout);

// `text` in double quotes, cut after `limit` bytes ("..." marks the cut), with '"', '\' and every
// byte outside printable ASCII escaped (\xNN): safe to put in any message.
std::string Printable(std::string_view text, std::size_t limit = 64);

}  // namespace mdrctl
