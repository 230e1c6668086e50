// Output of mdrctl: a run report, or any response message, as a readable table, CSV or JSON.
#pragma once

#include <google/protobuf/message.h>

#include <cstddef>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "mdr/analysis/loops.h"
#include "mdr/v1/analysis.pb.h"
#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene_file.pb.h"

namespace mdrctl {

enum class Format { kTable, kCsv, kJson };

// The proto3 JSON of a message, indented, every field present (ProtoJson, json_writer.h).
std::string ToJson(const google::protobuf::Message& message);

// Steps (the file's outputs as columns), energy per cycle and recorded profiles.
void PrintReport(const mdr::v1::RunReport& report, const mdr::v1::SceneFile& file, Format format,
                 std::FILE* out);
// The per-step states of an Apply (table and CSV: one row per step, a single contact's default
// columns, a torsional one's for a scene with torsion), or the JSON.
void PrintApplyResponse(const mdr::v1::ApplyResponse& response, const mdr::v1::Scene& scene,
                        Format format, std::FILE* out);
// Sessions one per row (table, CSV) or as a JSON list.
void PrintSessions(const std::vector<mdr::v1::Session>& sessions, Format format, std::FILE* out);
// Any message: table and CSV list every set field as "path value"; JSON as ToJson.
void PrintMessage(const google::protobuf::Message& message, Format format, std::FILE* out);

// "%.10g", the numbers of every table.
std::string FormatValue(double value);

// How a record's loop is written in tables, reports and plots: its position and force with their
// units (the library's, mdr::analysis::NamesOf) and the symbols of the figures built on them. A
// torsional record keeps every figure's definition with phi for u and M for F_x
// (docs/analysis.md, "Torsional records").
struct ChannelLabels {
  bool torsional = false;
  std::string position, position_unit;  // "u", "m" | "phi", "rad"
  std::string force, force_unit;        // "F_x", "N" | "M", "N m"
  std::string position_word;            // "displacement" | "twist"
  std::string force_word;               // "force" | "moment"
  std::string amplitude;                // "Q*" | "M*"
  std::string position_amplitude;       // "delta*" | "phi*"
  std::string half_opening;             // "delta_0" | "phi_0"
  std::string stiffness_unit;           // "N/m" | "N m/rad"
  std::string compliance_unit;          // "m/N" | "rad/(N m)"
  std::string mass_unit;                // "kg" | "kg m^2" (the moving mass: a moment of inertia)
};
ChannelLabels LabelsOf(mdr::analysis::LoopChannel channel);

// A column of the per-cycle table of a loop analysis.
struct CycleColumn {
  std::string header;    // table and Markdown, e.g. "Q* [N]"
  std::string csv_name;  // e.g. "force_amplitude"
  // The key of AnalyzeLoopsResponse.measures that labels the column ("contact.energy_ratio"),
  // or "" for none (sample indices, regime, flags).
  std::string figure;
  std::function<std::string(const mdr::v1::CycleFigures&)> cell;
};
// The columns for this analysis: the rig-free contact figures only with a rig compliance, the
// regime only with a scene (with the onset's C, or a torsional record's full-slip moment); a
// torsional record has no friction coefficient (M*/P is a length).
std::vector<CycleColumn> CycleColumns(const mdr::v1::AnalyzeLoopsResponse& analysis,
                                      const ChannelLabels& labels);
// "contact" or "contact+rig" for a figure, "" if `measures` does not name it.
std::string MeasureLabel(const mdr::v1::AnalyzeLoopsResponse& analysis, const std::string& figure);
// "partial slip", "gross slip", "sticking", or "-".
std::string RegimeLabel(mdr::v1::Regime regime);
// The estimates one per row (table: then the fit's figures and notes), or the JSON result.
void PrintFitResult(const mdr::v1::FitResult& fit, const ChannelLabels& labels, Format format,
                    std::FILE* out);
// One row per cycle (table, CSV; table adds which figures the rig biases) or the JSON response.
void PrintLoopAnalysis(const mdr::v1::AnalyzeLoopsResponse& analysis, const ChannelLabels& labels,
                       Format format, std::FILE* out);

// One run of a file of several (mdrctl loops --run-column) and its analysis.
struct RunAnalysis {
  std::string run;  // its id as the file writes it
  std::size_t samples = 0;
  std::size_t first_line = 0, last_line = 0;  // of its rows (a MAT file: elements)
  const mdr::v1::AnalyzeLoopsResponse* analysis = nullptr;
};
// The runs in the file's order. Table: a heading per run ("run "a": ...", the id quoted and
// escaped as Printable), then its table as PrintLoopAnalysis prints it; CSV: one table, the run's
// id (quoted so) first on every row; JSON: {"runs": [{run, samples, first_line, last_line,
// analysis}]}, the id as written, analysis the AnalyzeLoopsResponse.
void PrintRunAnalyses(const std::vector<RunAnalysis>& runs, const ChannelLabels& labels,
                      Format format, std::FILE* out);

}  // namespace mdrctl
