#include "report_format.h"

#include <google/protobuf/duration.pb.h>
#include <google/protobuf/text_format.h>
#include <google/protobuf/timestamp.pb.h>
#include <google/protobuf/util/time_util.h>

#include <algorithm>
#include <cctype>
#include <cstdio>

#include "json_writer.h"
#include "mdr/client/loading_path.h"
#include "rig_csv.h"

namespace mdrctl {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using mdr::v1::RunReport;
using mdr::v1::SceneFile;

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", value);
  return text;
}

// Rows of cells under a header; the first column is right-aligned (a step or cycle number).
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  void Print(Format format, std::FILE* out) const {
    if (format == Format::kCsv) {
      PrintCsvRow(header, out);
      for (const auto& row : rows) PrintCsvRow(row, out);
      return;
    }
    std::vector<std::size_t> widths(header.size(), 0);
    widths[0] = 5;
    for (std::size_t i = 1; i < header.size(); ++i) widths[i] = 18;
    for (const auto* row : AllRows()) {
      for (std::size_t i = 0; i < row->size(); ++i)
        widths[i] = std::max(widths[i], (*row)[i].size());
    }
    for (const auto* row : AllRows()) PrintTableRow(*row, widths, out);
  }

 private:
  std::vector<const std::vector<std::string>*> AllRows() const {
    std::vector<const std::vector<std::string>*> all{&header};
    for (const auto& row : rows) all.push_back(&row);
    return all;
  }
  static void PrintTableRow(const std::vector<std::string>& row,
                            const std::vector<std::size_t>& widths, std::FILE* out) {
    std::fprintf(out, "%*s", static_cast<int>(widths[0]), row[0].c_str());
    for (std::size_t i = 1; i < row.size(); ++i) {
      const bool last = i + 1 == row.size();
      std::fprintf(out, "  %-*s", last ? 0 : static_cast<int>(widths[i]), row[i].c_str());
    }
    std::fprintf(out, "\n");
  }
  static void PrintCsvRow(const std::vector<std::string>& row, std::FILE* out) {
    for (std::size_t i = 0; i < row.size(); ++i) {
      std::fprintf(out, "%s%s", i == 0 ? "" : ",", row[i].c_str());
    }
    std::fprintf(out, "\n");
  }
};

struct Column {
  const char* header;    // table
  const char* csv_name;  // CSV
  double (*value)(const RunReport::Row&);
};

Column ColumnFor(SceneFile::Output output) {
  using Row = RunReport::Row;
  switch (output) {
    case SceneFile::DEPTH:
      return {"delta [m]", "depth", [](const Row& r) { return r.state().depth(); }};
    case SceneFile::TANGENTIAL_DISPLACEMENT:
      return {"ux [m]", "tangential_displacement",
              [](const Row& r) { return r.state().tangential_displacement(); }};
    case SceneFile::NORMAL_FORCE:
      return {"F_N [N]", "normal_force", [](const Row& r) { return r.state().normal_force(); }};
    case SceneFile::TANGENTIAL_FORCE:
      return {"F_x [N]", "tangential_force",
              [](const Row& r) { return r.state().tangential_force(); }};
    case SceneFile::CONTACT_RADIUS:
      return {"a [m]", "contact_radius", [](const Row& r) { return r.state().contact_radius(); }};
    case SceneFile::DISSIPATED_ENERGY:
      return {"W [J]", "dissipated_energy",
              [](const Row& r) { return r.state().dissipated_energy(); }};
    case SceneFile::IN_CONTACT:
      return {"in contact", "in_contact",
              [](const Row& r) { return double(r.interface_totals().in_contact()); }};
    case SceneFile::STICKING:
      return {"sticking", "sticking",
              [](const Row& r) { return double(r.interface_totals().sticking()); }};
    case SceneFile::PARTIAL_SLIP:
      return {"partial slip", "partial_slip",
              [](const Row& r) { return double(r.interface_totals().partial_slip()); }};
    case SceneFile::GROSS_SLIP:
      return {"gross slip", "gross_slip",
              [](const Row& r) { return double(r.interface_totals().gross_slip()); }};
    case SceneFile::ACTUATOR_DISPLACEMENT:
      return {"u_act [m]", "actuator_displacement",
              [](const Row& r) { return r.state().actuator_displacement(); }};
    case SceneFile::ACTUATOR_DEPTH:
      return {"delta_act [m]", "actuator_depth",
              [](const Row& r) { return r.state().actuator_depth(); }};
    case SceneFile::TWIST:
      return {"phi [rad]", "twist", [](const Row& r) { return r.state().twist(); }};
    case SceneFile::TWISTING_MOMENT:
      return {"M [N m]", "twisting_moment",
              [](const Row& r) { return r.state().twisting_moment(); }};
    case SceneFile::FULL_SLIP_MOMENT:
      return {"M_slip [N m]", "full_slip_moment",
              [](const Row& r) { return r.state().full_slip_moment(); }};
    default:  // FRICTION_LIMIT; ValidateSceneFile rejects OUTPUT_UNSPECIFIED
      return {"mu*F_N [N]", "friction_limit",
              [](const Row& r) { return r.state().friction_limit(); }};
  }
}

std::vector<Column> ColumnsFor(const std::vector<SceneFile::Output>& outputs) {
  std::vector<Column> columns;
  for (const SceneFile::Output output : outputs) columns.push_back(ColumnFor(output));
  return columns;
}

Table StateTable(const std::vector<Column>& columns, Format format) {
  Table table;
  table.header.push_back("step");
  for (const Column& column : columns) {
    table.header.push_back(format == Format::kCsv ? column.csv_name : column.header);
  }
  return table;
}

std::vector<std::string> StateRow(const RunReport::Row& row, const std::vector<Column>& columns) {
  std::vector<std::string> cells{std::to_string(row.step())};
  for (const Column& column : columns) cells.push_back(Number(column.value(row)));
  return cells;
}

// Sections after the first: a blank line and a title ("# title" in CSV).
void PrintSectionTitle(const std::string& title, Format format, std::FILE* out) {
  std::fprintf(out, format == Format::kCsv ? "\n# %s\n" : "\n%s\n", title.c_str());
}

// torsion: the work of the twisting moment in place of that of F_x.
void PrintCycleEnergies(const RunReport& report, bool torsion, Format format, std::FILE* out) {
  if (report.cycle_energies().empty()) return;
  PrintSectionTitle("Energy dissipated per cycle", format, out);
  Table table;
  const char* work_csv = torsion ? "twisting_work" : "tangential_work";
  const char* work = torsion ? "work of M [J]" : "work of F_x [J]";
  table.header = format == Format::kCsv
                     ? std::vector<std::string>{"cycle", "segment", "dissipated_energy", work_csv}
                     : std::vector<std::string>{"cycle", "segment", "W [J]", work};
  for (const auto& energy : report.cycle_energies()) {
    table.rows.push_back({std::to_string(energy.cycle()), energy.origin(),
                          Number(energy.dissipated_energy()),
                          Number(torsion ? energy.twisting_work() : energy.tangential_work())});
  }
  table.Print(format, out);
}

// Per step: contacts in contact by slip fraction, one column per bin.
void PrintSlipHistograms(const RunReport& report, Format format, std::FILE* out) {
  const std::uint32_t bins = report.slip_histogram_bins();
  if (bins == 0) return;
  PrintSectionTitle("Slip histogram: contacts in contact by slip fraction (slipping radius / a)",
                    format, out);
  Table table;
  table.header.push_back("step");
  for (std::uint32_t b = 0; b < bins; ++b) {
    table.header.push_back(Number(static_cast<double>(b) / bins) + "-" +
                           Number(static_cast<double>(b + 1) / bins));
  }
  for (const auto& row : report.rows()) {
    std::vector<std::string> cells{std::to_string(row.step())};
    for (const std::uint64_t count : row.slip_histogram()) cells.push_back(std::to_string(count));
    table.rows.push_back(std::move(cells));
  }
  table.Print(format, out);
}

// Per step: the state of the contact of --contact-index, in a single contact's columns.
void PrintContactRows(const RunReport& report, Format format, std::FILE* out) {
  if (!report.has_contact_index()) return;
  PrintSectionTitle("Contact " + std::to_string(report.contact_index()), format, out);
  const std::vector<Column> columns = ColumnsFor(
      {SceneFile::DEPTH, SceneFile::TANGENTIAL_DISPLACEMENT, SceneFile::NORMAL_FORCE,
       SceneFile::TANGENTIAL_FORCE, SceneFile::CONTACT_RADIUS, SceneFile::DISSIPATED_ENERGY});
  Table table = StateTable(columns, format);
  for (const auto& row : report.rows()) {
    RunReport::Row contact;
    contact.set_step(row.step());
    *contact.mutable_state() = row.contact();
    table.rows.push_back(StateRow(contact, columns));
  }
  table.Print(format, out);
}

void PrintRecord(const RunReport::Record& record, Format format, std::FILE* out) {
  PrintSectionTitle("Record \"" + record.name() + "\" after step " + std::to_string(record.step()) +
                        " (a = " + Number(record.state().contact_radius()) + " m)",
                    format, out);
  for (const std::string& note : record.unavailable()) {
    std::fprintf(out, format == Format::kCsv ? "# not available: %s\n" : "not available: %s\n",
                 note.c_str());
  }
  Table table;
  if (record.torsion_tractions_size() > 0) {  // a torsional scene's: tau_phi by both routes
    table.header = format == Format::kCsv
                       ? std::vector<std::string>{"r", "tau_phi", "route_difference"}
                       : std::vector<std::string>{"r [m]", "tau_phi [Pa]", "route difference [Pa]"};
    for (const auto& traction : record.torsion_tractions()) {
      table.rows.push_back({Number(traction.radius()), Number(traction.value()),
                            Number(traction.route_difference())});
    }
    table.Print(format, out);
    return;
  }
  const bool tractions = record.tractions_size() == record.radii_size();
  table.header = format == Format::kCsv ? std::vector<std::string>{"i", "x", "u", "w"}
                                        : std::vector<std::string>{"i", "x [m]", "u [m]", "w [m]"};
  if (tractions) table.header.push_back(format == Format::kCsv ? "tau" : "tau [Pa]");
  for (int i = 0; i < record.radii_size(); ++i) {
    table.rows.push_back({std::to_string(i), Number(record.radii(i)),
                          Number(record.springs().tangential_displacement(i)),
                          Number(record.springs().normal_displacement(i))});
    if (tractions) table.rows.back().push_back(Number(record.tractions(i).value()));
  }
  table.Print(format, out);
}

// "name: value" lines of every set field, recursively ("state.normal_force").
void Flatten(const Message& message, const std::string& prefix,
             std::vector<std::vector<std::string>>* rows);

std::string ScalarValue(const Message& message, const FieldDescriptor* field, int index) {
  const auto* reflection = message.GetReflection();
  const bool repeated = field->is_repeated();
  switch (field->cpp_type()) {
    case FieldDescriptor::CPPTYPE_DOUBLE:
      return Number(repeated ? reflection->GetRepeatedDouble(message, field, index)
                             : reflection->GetDouble(message, field));
    case FieldDescriptor::CPPTYPE_STRING:
      return repeated ? reflection->GetRepeatedString(message, field, index)
                      : reflection->GetString(message, field);
    case FieldDescriptor::CPPTYPE_ENUM:
      return repeated ? reflection->GetRepeatedEnum(message, field, index)->name()
                      : reflection->GetEnum(message, field)->name();
    default: {
      std::string text;
      google::protobuf::TextFormat::PrintFieldValueToString(message, field, repeated ? index : -1,
                                                            &text);
      return text;
    }
  }
}

std::string TimeValue(const Message& message) {
  using google::protobuf::util::TimeUtil;
  if (const auto* time = dynamic_cast<const google::protobuf::Timestamp*>(&message)) {
    return TimeUtil::ToString(*time);
  }
  if (const auto* duration = dynamic_cast<const google::protobuf::Duration*>(&message)) {
    return TimeUtil::ToString(*duration);
  }
  return "";
}

void FlattenField(const Message& message, const FieldDescriptor* field, const std::string& path,
                  int index, std::vector<std::vector<std::string>>* rows) {
  const auto* reflection = message.GetReflection();
  if (field->cpp_type() != FieldDescriptor::CPPTYPE_MESSAGE) {
    rows->push_back({path, ScalarValue(message, field, index)});
    return;
  }
  const Message& child = field->is_repeated()
                             ? reflection->GetRepeatedMessage(message, field, index)
                             : reflection->GetMessage(message, field);
  const std::string time = TimeValue(child);
  if (!time.empty()) {
    rows->push_back({path, time});
  } else {
    Flatten(child, path, rows);
  }
}

void Flatten(const Message& message, const std::string& prefix,
             std::vector<std::vector<std::string>>* rows) {
  std::vector<const FieldDescriptor*> fields;
  message.GetReflection()->ListFields(message, &fields);
  for (const FieldDescriptor* field : fields) {
    const std::string path = prefix.empty() ? field->name() : prefix + "." + field->name();
    if (!field->is_repeated()) {
      FlattenField(message, field, path, -1, rows);
      continue;
    }
    const int size = message.GetReflection()->FieldSize(message, field);
    for (int i = 0; i < size; ++i) {
      FlattenField(message, field, path + "[" + std::to_string(i) + "]", i, rows);
    }
  }
}

}  // namespace

std::string ToJson(const Message& message) { return ProtoJson(message, true); }

void PrintReport(const RunReport& report, const SceneFile& file, Format format, std::FILE* out) {
  if (format == Format::kJson) {
    std::fputs(ToJson(report).c_str(), out);
    return;
  }
  const std::vector<Column> columns = ColumnsFor(mdr::client::TableOutputs(file));
  Table table = StateTable(columns, format);
  for (const auto& row : report.rows()) table.rows.push_back(StateRow(row, columns));
  table.Print(format, out);
  PrintCycleEnergies(report, file.scene().has_torsion(), format, out);
  PrintSlipHistograms(report, format, out);
  PrintContactRows(report, format, out);
  for (const auto& record : report.records()) PrintRecord(record, format, out);
}

void PrintApplyResponse(const mdr::v1::ApplyResponse& response, const mdr::v1::Scene& scene,
                        Format format, std::FILE* out) {
  if (format == Format::kJson) {
    std::fputs(ToJson(response).c_str(), out);
    return;
  }
  // The state's own columns: a single contact's, or a torsional one's (an interface's counts
  // would need a query of its totals).
  SceneFile file;
  if (scene.has_torsion()) file.mutable_scene()->mutable_torsion();
  const std::vector<Column> columns = ColumnsFor(mdr::client::TableOutputs(file));
  Table table = StateTable(columns, format);
  for (int i = 0; i < response.step_results_size(); ++i) {
    RunReport::Row row;
    row.set_step(i + 1);
    *row.mutable_state() = response.step_results(i).state();
    table.rows.push_back(StateRow(row, columns));
  }
  table.Print(format, out);
}

void PrintSessions(const std::vector<mdr::v1::Session>& sessions, Format format, std::FILE* out) {
  if (format == Format::kJson) {
    mdr::v1::ListSessionsResponse all;
    for (const auto& session : sessions) *all.add_sessions() = session;
    std::fputs(ToJson(all).c_str(), out);
    return;
  }
  Table table;
  table.header = {"steps", "name", "F_N [N]", "F_x [N]", "expire_time", "availability"};
  if (format == Format::kCsv)
    table.header = {"steps",       "name",        "normal_force", "tangential_force",
                    "expire_time", "availability"};
  for (const auto& session : sessions) {
    const std::string expires =
        session.has_expire_time() ? TimeValue(session.expire_time()) : "never";
    if (session.availability() == mdr::v1::Session::AVAILABILITY_UNAVAILABLE) {
      // No state to show: the reason is what the operator needs.
      table.rows.push_back(
          {"-", session.name(), "-", "-", expires, "unavailable: " + session.unavailable_reason()});
      continue;
    }
    table.rows.push_back({std::to_string(session.state().applied_steps()), session.name(),
                          Number(session.state().normal_force()),
                          Number(session.state().tangential_force()), expires, "active"});
  }
  table.Print(format, out);
}

std::string FormatValue(double value) { return Number(value); }

ChannelLabels LabelsOf(mdr::analysis::LoopChannel channel) {
  const mdr::analysis::ChannelNames names = mdr::analysis::NamesOf(channel);
  if (channel == mdr::analysis::LoopChannel::kTorsional) {
    return {.torsional = true,
            .position = "phi",
            .position_unit = names.position_unit,
            .force = "M",
            .force_unit = names.force_unit,
            .position_word = "twist",
            .force_word = "moment",
            .amplitude = "M*",
            .position_amplitude = "phi*",
            .half_opening = "phi_0",
            .stiffness_unit = "N m/rad",
            .compliance_unit = "rad/(N m)",
            .mass_unit = "kg m^2"};
  }
  return {.torsional = false,
          .position = "u",
          .position_unit = names.position_unit,
          .force = "F_x",
          .force_unit = names.force_unit,
          .position_word = "displacement",
          .force_word = "force",
          .amplitude = "Q*",
          .position_amplitude = "delta*",
          .half_opening = "delta_0",
          .stiffness_unit = "N/m",
          .compliance_unit = "m/N",
          .mass_unit = "kg"};
}

std::string RegimeLabel(mdr::v1::Regime regime) {
  switch (regime) {
    case mdr::v1::REGIME_STICKING:
      return "sticking";
    case mdr::v1::REGIME_PARTIAL_SLIP:
      return "partial slip";
    case mdr::v1::REGIME_GROSS_SLIP:
      return "gross slip";
    default:
      return "-";
  }
}

std::string MeasureLabel(const mdr::v1::AnalyzeLoopsResponse& analysis, const std::string& figure) {
  const auto found = analysis.measures().find(figure);
  if (found == analysis.measures().end()) return "";
  return found->second == mdr::v1::MEASURES_CONTACT ? "contact" : "contact+rig";
}

std::vector<CycleColumn> CycleColumns(const mdr::v1::AnalyzeLoopsResponse& analysis,
                                      const ChannelLabels& labels) {
  using Cycle = mdr::v1::CycleFigures;
  const auto number = [](double (Cycle::*get)() const) {
    return [get](const Cycle& c) { return Number((c.*get)()); };
  };
  const auto contact = [](double (mdr::v1::ContactFigures::*get)() const) {
    return [get](const Cycle& c) { return Number((c.contact().*get)()); };
  };
  const auto in = [](const std::string& symbol, const std::string& unit) {
    return symbol + " [" + unit + "]";
  };
  std::vector<CycleColumn> columns{
      {"first", "first_sample", "",
       [](const Cycle& c) { return std::to_string(c.first_sample()); }},
      {"last", "last_sample", "", [](const Cycle& c) { return std::to_string(c.last_sample()); }},
      {in(labels.amplitude, labels.force_unit), "force_amplitude", "force_amplitude",
       number(&Cycle::force_amplitude)},
      {"Ed [J]", "dissipated_energy", "dissipated_energy", number(&Cycle::dissipated_energy)},
      {in(labels.half_opening, labels.position_unit), "half_opening", "half_opening",
       number(&Cycle::half_opening)},
      {"C", "system_free_ratio", "system_free_ratio", number(&Cycle::system_free_ratio)},
      {"P [N]", "normal_force", "normal_force", number(&Cycle::normal_force)}};
  if (!labels.torsional) {  // a torsional record's M*/P is a length, not a friction coefficient
    columns.push_back({"mu", "friction_coefficient", "friction_coefficient",
                       number(&Cycle::friction_coefficient)});
  }
  columns.insert(columns.end(),
                 {{in(labels.position_amplitude, labels.position_unit), "displacement_amplitude",
                   "displacement_amplitude", number(&Cycle::displacement_amplitude)},
                  {"A", "energy_ratio", "energy_ratio", number(&Cycle::energy_ratio)},
                  {"B", "sliding_ratio", "sliding_ratio", number(&Cycle::sliding_ratio)},
                  {in("k_sec", labels.stiffness_unit), "secant_stiffness", "secant_stiffness",
                   number(&Cycle::secant_stiffness)}});
  const auto has_contact = [](const Cycle& c) { return c.has_contact(); };
  if (std::any_of(analysis.cycles().begin(), analysis.cycles().end(), has_contact)) {
    using Contact = mdr::v1::ContactFigures;
    columns.push_back({in(labels.position_amplitude + "_c", labels.position_unit),
                       "contact_displacement_amplitude", "contact.displacement_amplitude",
                       contact(&Contact::displacement_amplitude)});
    columns.push_back(
        {"A_c", "contact_energy_ratio", "contact.energy_ratio", contact(&Contact::energy_ratio)});
    columns.push_back({"B_c", "contact_sliding_ratio", "contact.sliding_ratio",
                       contact(&Contact::sliding_ratio)});
  }
  const auto has_regime = [](const Cycle& c) { return c.regime() != mdr::v1::REGIME_UNSPECIFIED; };
  if (std::any_of(analysis.cycles().begin(), analysis.cycles().end(), has_regime)) {
    columns.push_back(
        {"regime", "regime", "", [](const Cycle& c) { return RegimeLabel(c.regime()); }});
    columns.push_back(labels.torsional
                          ? CycleColumn{in("M_slip", labels.force_unit), "full_slip_moment", "",
                                        number(&Cycle::full_slip_moment)}
                          : CycleColumn{"C onset", "onset_system_free_ratio", "",
                                        number(&Cycle::onset_system_free_ratio)});
  }
  columns.push_back({"flags", "flags", "", [](const Cycle& c) {
                       std::string flags;
                       if (c.flags().not_closed()) flags += "not_closed ";
                       if (c.flags().asymmetric()) flags += "asymmetric ";
                       if (c.flags().hooked()) flags += "hooked ";
                       if (flags.empty()) return std::string("-");
                       flags.pop_back();
                       return flags;
                     }});
  return columns;
}

std::string NuisanceLabel(mdr::v1::Nuisance nuisance) {
  std::string name = mdr::v1::Nuisance_Name(nuisance).substr(9);  // NUISANCE_
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return name;
}

void PrintFitResult(const mdr::v1::FitResult& result, const ChannelLabels& labels, Format format,
                    std::FILE* out) {
  mdr::v1::FitResult fit = result;
  fit.clear_models();  // sample by sample: for plots (the report's), not for the terminal
  if (format == Format::kJson) {
    std::fputs(ToJson(fit).c_str(), out);
    return;
  }
  Table table;
  table.header = {"k",        "parameter", "estimate",  "standard_error",
                  "lower_95", "upper_95",  "identified"};
  for (int k = 0; k < fit.estimates_size(); ++k) {
    const auto& e = fit.estimates(k);
    std::string name = mdr::v1::FitParameter_Name(e.parameter()).substr(14);  // FIT_PARAMETER_
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    table.rows.push_back({std::to_string(k + 1), name, Number(e.value()),
                          Number(e.standard_error()), Number(e.lower_95()), Number(e.upper_95()),
                          e.identified() ? "yes" : "no"});
  }
  table.Print(format, out);
  if (format != Format::kTable) return;
  // What each set says of the model, and the nuisances.
  Table sets;
  sets.header = {"set",
                 labels.position + "_noise [" + labels.position_unit + "]",
                 labels.force + "_noise [" + labels.force_unit + "]",
                 "chi2",
                 "structure_p",
                 "gross_slip",
                 "turning_points",
                 "verdict"};
  for (int i = 0; i < fit.sets_size(); ++i) {
    const auto& s = fit.sets(i);
    sets.rows.push_back({std::to_string(i), Number(s.displacement_noise()), Number(s.force_noise()),
                         Number(s.reduced_chi_square()), Number(s.structure_p_value()),
                         s.gross_slip() ? "yes" : "no", std::to_string(s.turning_points()),
                         s.load_mismatch() ? "LOAD MISMATCH"
                         : s.misfit()      ? "MISFIT"
                                           : "adequate"});
  }
  std::fputc('\n', out);
  sets.Print(format, out);
  Table nuisances;
  nuisances.header = {"nuisance", "set",      "estimate",  "standard_error",
                      "lower_95", "upper_95", "identified"};
  for (const auto& e : fit.nuisances()) {
    nuisances.rows.push_back({NuisanceLabel(e.nuisance()),
                              e.has_set() ? std::to_string(e.set()) : "all", Number(e.value()),
                              Number(e.standard_error()), Number(e.lower_95()),
                              Number(e.upper_95()), e.identified() ? "yes" : "no"});
  }
  if (!nuisances.rows.empty()) {
    std::fputc('\n', out);
    nuisances.Print(format, out);
  }
  std::fprintf(out,
               "\nresidual RMS %s %s over %llu samples (reduced chi-square %s), %d iterations%s, "
               "condition number %s: %s\n",
               Number(fit.residual_rms()).c_str(), labels.force_unit.c_str(),
               static_cast<unsigned long long>(fit.residuals()),
               Number(fit.reduced_chi_square()).c_str(), fit.iterations(),
               fit.converged() ? ", converged" : ", NOT converged",
               Number(fit.condition_number()).c_str(),
               !fit.adequate()    ? "the model does NOT explain the data (see the notes)"
               : fit.identified() ? "every parameter identified"
                                  : "NOT every parameter identified");
  for (const std::string& note : fit.notes()) std::fprintf(out, "note: %s\n", note.c_str());
  if (fit.has_guessed_rig_compliance()) {
    std::fprintf(out, "rig compliance from the reversal slopes (a starting point): %s %s\n",
                 Number(fit.guessed_rig_compliance()).c_str(), labels.compliance_unit.c_str());
  }
}

namespace {

// The per-cycle rows of an analysis under `columns`, after `lead` (the run's id, or nothing).
void AddCycleRows(const mdr::v1::AnalyzeLoopsResponse& analysis,
                  const std::vector<CycleColumn>& columns, Format format,
                  const std::vector<std::string>& lead, Table* table) {
  for (int i = 0; i < analysis.cycles_size(); ++i) {
    std::vector<std::string> row = lead;
    row.push_back(std::to_string(i + 1));
    for (const CycleColumn& column : columns) {
      std::string cell = column.cell(analysis.cycles(i));
      // A CSV cell holds no separator: flags are joined by '|'.
      if (format == Format::kCsv) std::replace(cell.begin(), cell.end(), ' ', '|');
      row.push_back(cell);
    }
    table->rows.push_back(std::move(row));
  }
}

Table CycleTable(const std::vector<CycleColumn>& columns, Format format,
                 std::vector<std::string> header) {
  Table table;
  table.header = std::move(header);
  table.header.push_back("cycle");
  for (const CycleColumn& column : columns) {
    table.header.push_back(format == Format::kCsv ? column.csv_name : column.header);
  }
  return table;
}

void PrintAnalysisFooter(const mdr::v1::AnalyzeLoopsResponse& analysis,
                         const std::vector<CycleColumn>& columns, const ChannelLabels& labels,
                         std::FILE* out) {
  std::string biased;
  for (const CycleColumn& column : columns) {
    if (MeasureLabel(analysis, column.figure) == "contact+rig") {
      biased += (biased.empty() ? "" : ", ") + column.header;
    }
  }
  std::fprintf(out,
               "\nbiased by the rig's compliance (contact+rig): %s; the other figures measure the "
               "contact alone\n",
               biased.c_str());
  std::fprintf(out, "reversal threshold %s %s, friction drift %s%s\n",
               Number(analysis.reversal_threshold()).c_str(), labels.position_unit.c_str(),
               Number(analysis.friction_drift()).c_str(),
               analysis.friction_drifts() ? " (drifts)" : "");
}

}  // namespace

void PrintLoopAnalysis(const mdr::v1::AnalyzeLoopsResponse& analysis, const ChannelLabels& labels,
                       Format format, std::FILE* out) {
  if (format == Format::kJson) {
    std::fputs(ToJson(analysis).c_str(), out);
    return;
  }
  const std::vector<CycleColumn> columns = CycleColumns(analysis, labels);
  Table table = CycleTable(columns, format, {});
  AddCycleRows(analysis, columns, format, {}, &table);
  table.Print(format, out);
  if (format == Format::kTable) PrintAnalysisFooter(analysis, columns, labels, out);
}

void PrintRunAnalyses(const std::vector<RunAnalysis>& runs, const ChannelLabels& labels,
                      Format format, std::FILE* out) {
  if (format == Format::kJson) {
    JsonWriter json;
    json.BeginObject().Key("runs").BeginArray();
    for (const RunAnalysis& run : runs) {
      json.BeginObject().Key("run").String(run.run);
      json.Key("samples").Number(static_cast<double>(run.samples));
      json.Key("first_line").Number(static_cast<double>(run.first_line));
      json.Key("last_line").Number(static_cast<double>(run.last_line));
      json.Key("analysis").Message(*run.analysis).EndObject();
    }
    json.EndArray().EndObject();
    std::fputs(json.Pretty().c_str(), out);
    return;
  }
  if (format == Format::kTable) {
    for (const RunAnalysis& run : runs) {
      std::fprintf(out, "%srun %s: %zu samples, lines %zu to %zu\n",
                   &run == &runs.front() ? "" : "\n", Printable(run.run).c_str(), run.samples,
                   run.first_line, run.last_line);
      PrintLoopAnalysis(*run.analysis, labels, format, out);
    }
    return;
  }
  // One CSV table: its columns are those of every run's cycles together (a run without cycles
  // would otherwise drop the contact columns).
  mdr::v1::AnalyzeLoopsResponse all;
  for (const RunAnalysis& run : runs) {
    for (const auto& cycle : run.analysis->cycles()) *all.add_cycles() = cycle;
  }
  const std::vector<CycleColumn> columns = CycleColumns(all, labels);
  Table table = CycleTable(columns, format, {"run"});
  for (const RunAnalysis& run : runs) {
    AddCycleRows(*run.analysis, columns, format, {Printable(run.run)}, &table);
  }
  table.Print(format, out);
}

void PrintMessage(const Message& message, Format format, std::FILE* out) {
  if (format == Format::kJson) {
    std::fputs(ToJson(message).c_str(), out);
    return;
  }
  std::vector<std::vector<std::string>> rows;
  Flatten(message, "", &rows);
  for (const auto& row : rows) {
    std::fprintf(out, format == Format::kCsv ? "%s,%s\n" : "%-40s  %s\n", row[0].c_str(),
                 row[1].c_str());
  }
}

}  // namespace mdrctl
