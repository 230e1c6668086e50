#include "analysis_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "json_writer.h"
#include "report_format.h"

namespace mdrctl {
namespace {

using mdr::v1::AnalyzeLoopsResponse;
using mdr::v1::CycleFigures;
using mdr::v1::FitResult;
using mdr::v1::ParameterEstimate;

std::string Num(double value, int digits = 6) {
  if (std::isnan(value)) return "n/a";
  char text[40];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

// A Markdown table cell: '|' would end the cell.
std::string Cell(std::string text) {
  for (std::size_t i = text.find('|'); i != std::string::npos; i = text.find('|', i + 2)) {
    text.replace(i, 1, "\\|");
  }
  return text;
}

// A Markdown code span of text whose backticks are replaced.
std::string Code(std::string text) {
  for (char& c : text) {
    if (c == '`') c = '\'';
  }
  return "`" + text + "`";
}

class MarkdownTable {
 public:
  explicit MarkdownTable(std::vector<std::string> header) : header_(std::move(header)) {}
  void Row(std::vector<std::string> cells) { rows_.push_back(std::move(cells)); }
  std::string str() const {
    std::string out = Line(header_);
    out += "|";
    for (std::size_t i = 0; i < header_.size(); ++i) out += "---|";
    out += "\n";
    for (const auto& row : rows_) out += Line(row);
    return out;
  }

 private:
  static std::string Line(const std::vector<std::string>& cells) {
    std::string line = "|";
    for (const std::string& cell : cells) {
      line += ' ';
      line += Cell(cell);
      line += " |";
    }
    return line + "\n";
  }
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

ChannelLabels SetLabels(const ReportSet& set) { return LabelsOf(set.layout.channel); }

ChannelLabels CampaignLabels(const Campaign& campaign) { return LabelsOf(campaign.channel); }

// The per-cycle table, each figure's header labelled with what it measures.
std::string CycleTable(const AnalyzeLoopsResponse& analysis, const ChannelLabels& labels) {
  const std::vector<CycleColumn> columns = CycleColumns(analysis, labels);
  std::vector<std::string> header{"cycle"};
  for (const CycleColumn& column : columns) {
    const std::string label = MeasureLabel(analysis, column.figure);
    header.push_back(label.empty() ? column.header : column.header + " (" + label + ")");
  }
  MarkdownTable table(header);
  for (int i = 0; i < analysis.cycles_size(); ++i) {
    std::vector<std::string> row{std::to_string(i + 1)};
    for (const CycleColumn& column : columns) row.push_back(column.cell(analysis.cycles(i)));
    table.Row(row);
  }
  return table.str();
}

// "3 partial slip, 2 gross slip", or "" without regimes.
std::string RegimeCounts(const AnalyzeLoopsResponse& analysis) {
  std::map<std::string, int> counts;
  for (const CycleFigures& c : analysis.cycles()) {
    if (c.regime() != mdr::v1::REGIME_UNSPECIFIED) ++counts[RegimeLabel(c.regime())];
  }
  std::string text;
  for (const auto& [name, count] : counts) {
    text += (text.empty() ? "" : ", ") + std::to_string(count) + " " + name;
  }
  return text;
}

std::string FlagSummary(const AnalyzeLoopsResponse& analysis) {
  int not_closed = 0, asymmetric = 0, hooked = 0;
  for (const CycleFigures& c : analysis.cycles()) {
    not_closed += c.flags().not_closed();
    asymmetric += c.flags().asymmetric();
    hooked += c.flags().hooked();
  }
  if (not_closed + asymmetric + hooked == 0) return "no cycle is flagged";
  return "flagged cycles: " + std::to_string(not_closed) + " not closed, " +
         std::to_string(asymmetric) + " asymmetric, " + std::to_string(hooked) + " hooked";
}

std::string AnalysisSummary(const AnalyzeLoopsResponse& analysis, const ChannelLabels& labels) {
  std::string text = std::to_string(analysis.cycles_size()) + " complete cycles between " +
                     std::to_string(analysis.reversals_size()) + " reversals (threshold " +
                     Num(analysis.reversal_threshold()) + " " + labels.position_unit +
                     "); friction drift over the run " + Num(analysis.friction_drift()) +
                     (analysis.friction_drifts() ? " (**drifts**)" : "") + "; " +
                     FlagSummary(analysis) + ".";
  const std::string regimes = RegimeCounts(analysis);
  if (!regimes.empty()) text += " Regimes: " + regimes + ".";
  return text;
}

std::string MeasuresNote(const ChannelLabels& labels) {
  return "Labels: *contact* figures are the contact's own whatever the rig in series (" +
         labels.force_word +
         "s, dissipated energy, half-opening, C); *contact+rig* figures include the rig's "
         "compliance (" +
         labels.position_word +
         " amplitude, A, B, stiffnesses) and are biased by it (docs/analysis.md, \"The rig in "
         "series\").";
}

std::string PlotsSection(const Plots& plots, const std::vector<std::string>& captions) {
  std::string md = "## Plots\n\n";
  if (!plots.skipped.empty()) return md + "Plots were skipped: " + plots.skipped + "\n";
  for (std::size_t i = 0; i < plots.pngs.size(); ++i) {
    const std::string caption = i < captions.size() ? captions[i] : plots.pngs[i];
    md += "**" + caption + "**\n\n![" + caption + "](" + plots.pngs[i] + ")\n\n";
  }
  return md;
}

std::string LayoutText(const CsvLayout& layout) {
  std::string text = IsTorsional(layout)
                         ? "twist " + Code(layout.twist_column) + " (x" + Num(layout.twist_unit) +
                               " rad), twisting moment " + Code(layout.moment_column) + " (x" +
                               Num(layout.moment_unit) + " N m)"
                         : "displacement " + Code(layout.displacement_column) + " (x" +
                               Num(layout.displacement_unit) + " m), tangential force " +
                               Code(layout.force_column) + " (x" + Num(layout.force_unit) + " N)";
  if (!layout.normal_force_column.empty()) {
    text += ", normal force " + Code(layout.normal_force_column) +
            (IsTorsional(layout) ? " (x" + Num(layout.force_unit) + " N)" : "");
  }
  if (!layout.time_column.empty()) {
    text += ", time " + Code(layout.time_column) + " (x" + Num(layout.time_unit) + " s)";
  }
  return text;
}

// A torsional layout: its channel, columns and units (a tangential one keeps the keys it always
// had).
void WriteTorsionalLayout(const CsvLayout& layout, JsonWriter* json) {
  json->BeginObject()
      .Key("channel")
      .String("torsional")
      .Key("twist_column")
      .String(layout.twist_column)
      .Key("moment_column")
      .String(layout.moment_column)
      .Key("normal_force_column")
      .String(layout.normal_force_column)
      .Key("time_column")
      .String(layout.time_column)
      .Key("twist_unit_rad")
      .Number(layout.twist_unit)
      .Key("moment_unit_n_m")
      .Number(layout.moment_unit)
      .Key("normal_force_unit_n")
      .Number(layout.force_unit)
      .Key("time_unit_s")
      .Number(layout.time_unit)
      .EndObject();
}

void WriteLayout(const CsvLayout& layout, JsonWriter* json) {
  if (IsTorsional(layout)) {
    WriteTorsionalLayout(layout, json);
    return;
  }
  json->BeginObject()
      .Key("displacement_column")
      .String(layout.displacement_column)
      .Key("force_column")
      .String(layout.force_column)
      .Key("normal_force_column")
      .String(layout.normal_force_column)
      .Key("time_column")
      .String(layout.time_column)
      .Key("displacement_unit_m")
      .Number(layout.displacement_unit)
      .Key("force_unit_n")
      .Number(layout.force_unit)
      .Key("time_unit_s")
      .Number(layout.time_unit)
      .EndObject();
}

// The analysis without its timing (a re-run reproduces the report).
AnalyzeLoopsResponse Untimed(AnalyzeLoopsResponse analysis) {
  analysis.clear_compute_seconds();
  return analysis;
}

// ---- fit ----

struct TruthCheck {
  bool known = false;
  double truth = 0;
  bool inside = false;
};

TruthCheck CheckTruth(const Campaign& campaign, const ParameterEstimate& e) {
  const auto found = campaign.truth.find(FitParameterName(e.parameter()));
  if (found == campaign.truth.end()) return {};
  return {true, found->second, e.lower_95() <= found->second && found->second <= e.upper_95()};
}

// Which sets are synthetic, each distinct "# SYNTHETIC" comment once with its files.
std::string SyntheticSection(const std::vector<ReportSet>& sets) {
  std::vector<std::pair<std::string, std::vector<std::string>>> notes;
  std::size_t synthetic = 0;
  for (const ReportSet& set : sets) {
    if (!set.csv.synthetic) continue;
    ++synthetic;
    auto same = std::find_if(notes.begin(), notes.end(),
                             [&](const auto& note) { return note.first == *set.csv.synthetic; });
    if (same == notes.end()) same = notes.insert(notes.end(), {*set.csv.synthetic, {}});
    same->second.push_back(set.label);
  }
  if (synthetic == 0) return "";
  std::string md =
      "> **Synthetic inputs.** " +
      (synthetic == sets.size() ? std::string("Every loop set is synthetic")
                                : std::to_string(synthetic) + " of " + std::to_string(sets.size()) +
                                      " loop sets are synthetic") +
      ", as the files say:\n";
  for (const auto& [note, files] : notes) {
    std::string list;
    for (const std::string& file : files) list += (list.empty() ? "" : ", ") + Code(file);
    md += "> - " + (files.size() == synthetic && synthetic == sets.size() ? "all" : list) + ": " +
          Code(note) + "\n";
  }
  return md + "\n";
}

std::string FittedSection(const FitReport& report) {
  const Campaign& campaign = *report.campaign;
  const ChannelLabels labels = CampaignLabels(campaign);
  std::string md = "## What was fitted\n\n";
  md += "Scene: " +
        (campaign.scene_source == "inline" ? std::string("inline in the campaign")
                                           : Code(campaign.scene_source)) +
        "; free parameters (the others keep the scene's values):\n\n";
  MarkdownTable free({"parameter", "initial", "lower", "upper"});
  for (const auto& p : report.request.free()) {
    free.Row({FitParameterName(p.parameter()),
              p.has_initial() ? Num(p.initial(), 8) : "the scene's", Num(p.lower(), 8),
              Num(p.upper(), 8)});
  }
  md += free.str() +
        "\nLoop sets, each replayed through the exact engine at its normal force; "
        "residuals (" +
        labels.force + " measured - fitted) count from reversal number " +
        std::to_string(report.request.has_burn_in_reversals() ? report.request.burn_in_reversals()
                                                              : 2) +
        " of each set on:\n\n";
  MarkdownTable sets({"file", "P [N]", "samples", "counted from sample", "cycles", "columns"});
  for (std::size_t i = 0; i < report.sets.size(); ++i) {
    const ReportSet& set = report.sets[i];
    std::string load = Num(set.normal_force);
    if (i < static_cast<std::size_t>(report.fit.sets_size()) &&
        report.fit.sets(static_cast<int>(i)).normal_force_measured()) {
      const mdr::v1::SetFit& f = report.fit.sets(static_cast<int>(i));
      load = "measured: " + Num(f.normal_force()) + " [" + Num(f.normal_force_min()) + ", " +
             Num(f.normal_force_max()) + "]" +
             (set.declared_normal_force ? ", declared " + Num(*set.declared_normal_force) : "");
    }
    sets.Row({Code(set.label), load, std::to_string(set.csv.lines.size()),
              std::to_string(set.first_counted), std::to_string(set.analysis.cycles_size()),
              LayoutText(set.layout)});
  }
  const auto& nuisances = report.request.nuisances();
  std::string asked;
  for (const auto& [on, name] :
       {std::pair{nuisances.force_offset(), "a " + labels.force_word + " offset per set"},
        std::pair{nuisances.displacement_drift(), "a " + labels.position_word + " drift per set"},
        std::pair{nuisances.moving_mass(),
                  std::string(labels.torsional ? "a moment of inertia" : "a moving mass")}}) {
    if (on) asked += (asked.empty() ? "" : ", ") + name;
  }
  md += sets.str() + "\nFitted with them, always: every set's press point (its " +
        labels.position_word +
        " offset) and every turning point from the first counted reversal on; " +
        (asked.empty() ? std::string("no other nuisance parameters") : "and " + asked) +
        ". The replayed path is each set's " + labels.position_word +
        " smoothed within its half-cycles between the fitted turning points" +
        (labels.torsional ? ", through the shaft's torsional compliance at the set's constant "
                            "normal force"
                          : "") +
        "; each residual is weighed by its effective variance (docs/analysis.md, "
        "\"Identification\").\n\n";
  return md;
}

// The noise of each set's channels as the fit estimated it, and whether the model explains the
// set to that noise.
std::string AdequacySection(const FitReport& report) {
  const FitResult& fit = report.fit;
  const ChannelLabels labels = CampaignLabels(*report.campaign);
  const auto in = [](const std::string& what, const std::string& unit) {
    return what + " [" + unit + "]";
  };
  std::string md =
      "### Noise and model adequacy per set\n\n"
      "Each channel's noise is estimated from its own samples (the spread of their third "
      "differences; a lag-1 correlation of those differences near -0.75 says the noise is "
      "independent from sample to sample). The model explains a set when its residuals, each "
      "over its noise, have a reduced chi-square near 1 (a misfit above 1.5) and show no "
      "structure repeated over the cycles (a misfit below p = 1e-4).\n\n";
  MarkdownTable table({"set", in(labels.position + " noise", labels.position_unit),
                       in(labels.force + " noise", labels.force_unit), "F_N noise [N]",
                       labels.position + " / " + labels.force + " noise corr.",
                       in("residual RMS", labels.force_unit), "reduced chi-square",
                       "autocorrelation", "structure p", "slip", "verdict"});
  for (int i = 0; i < fit.sets_size() && i < static_cast<int>(report.sets.size()); ++i) {
    const mdr::v1::SetFit& s = fit.sets(i);
    table.Row(
        {Code(report.sets[static_cast<std::size_t>(i)].label), Num(s.displacement_noise(), 3),
         Num(s.force_noise(), 3), s.normal_force_measured() ? Num(s.normal_force_noise(), 3) : "-",
         Num(s.displacement_noise_correlation(), 2) + " / " + Num(s.force_noise_correlation(), 2),
         Num(s.residual_rms(), 4), Num(s.reduced_chi_square(), 4), Num(s.autocorrelation(), 3),
         Num(s.structure_p_value(), 3), s.gross_slip() ? "gross" : "partial",
         s.load_mismatch() ? "**load mismatch**"
         : s.misfit()      ? "**misfit**"
                           : "adequate"});
  }
  md += table.str() + "\n" +
        (fit.adequate() ? "The model explains every set to its noise.\n\n"
                        : "**The model does not explain every set**: the estimates are not "
                          "identified whatever their intervals say (notes below).\n\n");
  return md;
}

std::string NuisanceSection(const FitReport& report) {
  const FitResult& fit = report.fit;
  if (fit.nuisances_size() == 0) return "";
  std::string md =
      "### Nuisance parameters\n\nEach with its Wald interval and, per free "
      "parameter, how far holding it at zero would move the estimate (to first "
      "order):\n\n";
  std::vector<std::string> header{"nuisance",       "set",           "estimate",
                                  "standard error", "95 % interval", "verdict"};
  for (const ParameterEstimate& e : fit.estimates()) {
    header.push_back("effect on " + std::string(FitParameterName(e.parameter())));
  }
  MarkdownTable table(header);
  for (const mdr::v1::NuisanceEstimate& e : fit.nuisances()) {
    std::string name = mdr::v1::Nuisance_Name(e.nuisance()).substr(9);
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    std::vector<std::string> row{
        name,
        e.has_set() && e.set() < report.sets.size() ? Code(report.sets[e.set()].label) : "all",
        Num(e.value(), 6),
        Num(e.standard_error(), 3),
        "[" + Num(e.lower_95(), 6) + ", " + Num(e.upper_95(), 6) + "]",
        e.identified() ? "identified" : "not identified"};
    for (double effect : e.effect()) row.push_back(Num(effect, 3));
    table.Row(row);
  }
  return md + table.str() + "\n";
}

// A fit parameter's unit in this campaign (a torsional one's compliance and offset in rad).
std::string ParameterUnit(mdr::v1::FitParameter parameter, const Campaign& campaign) {
  const ChannelLabels labels = CampaignLabels(campaign);
  switch (parameter) {
    case mdr::v1::FIT_PARAMETER_EFFECTIVE_MODULUS:
    case mdr::v1::FIT_PARAMETER_TORSIONAL_MODULUS:
      return "Pa";
    case mdr::v1::FIT_PARAMETER_PROFILE_SCALE:
      return campaign.scene.has_sphere() ? "m" : "the power law's";
    case mdr::v1::FIT_PARAMETER_RIG_COMPLIANCE:
      return labels.compliance_unit;
    case mdr::v1::FIT_PARAMETER_DISPLACEMENT_OFFSET:
      return labels.position_unit;
    default:
      return "1";
  }
}

// A torsional fit's scene besides the estimates: the G_t and the shaft it replayed.
std::string FittedTorsionText(const FitReport& report) {
  const mdr::v1::Scene& fitted = report.fit.fitted_scene();
  if (!fitted.has_torsion()) return "";
  return "The fitted scene's torsion: torsional_modulus G_t = " +
         Num(report.fitted_torsional_modulus, 8) + " Pa" +
         (fitted.torsion().has_torsional_modulus() ? "" : " (its material's)") +
         ", rig_compliance " + Num(fitted.torsion().rig_compliance(), 8) +
         " rad/(N m) (the shaft between the contact and the twist sensor).\n\n";
}

std::string EstimatesSection(const FitReport& report) {
  const FitResult& fit = report.fit;
  const ChannelLabels labels = CampaignLabels(*report.campaign);
  std::string md = "## Estimates\n\n";
  MarkdownTable table({"parameter", "unit", "estimate", "standard error", "95 % interval",
                       "relative half-width", "interval", "verdict"});
  for (const ParameterEstimate& e : fit.estimates()) {
    table.Row({FitParameterName(e.parameter()), ParameterUnit(e.parameter(), *report.campaign),
               Num(e.value(), 8), Num(e.standard_error(), 3),
               "[" + Num(e.lower_95(), 8) + ", " + Num(e.upper_95(), 8) + "]",
               Num(0.5 * (e.upper_95() - e.lower_95()) / std::abs(e.value()), 3),
               e.interval() == mdr::v1::INTERVAL_METHOD_HALF_CYCLE_SANDWICH ? "half-cycle sandwich"
                                                                            : "Wald",
               e.identified() ? "identified" : "**not identified**"});
  }
  md += table.str() + "\n" + FittedTorsionText(report);
  const std::string& unit = labels.force_unit;
  md += std::string(fit.converged() ? "The fit converged" : "**The fit did not converge**") +
        " after " + std::to_string(fit.iterations()) + " iterations; residual RMS " +
        Num(fit.residual_rms()) + " " + unit + " over " + std::to_string(fit.residuals()) +
        " counted samples.\n\n";
  md += "Replay check: the model's contact " + labels.force_word +
        "s, replayed through a session of the fitted scene along the model's own " +
        (labels.torsional ? "contact twist (its actuator twist less the shaft's C M: sessions "
                            "hold no shaft) at its normal force"
                          : "actuator path (and measured normal force)") +
        ", agree to " + Num(report.replay_difference, 3) + " " + unit +
        " at most; the residual RMS of the model the fit returned is " +
        Num(report.replay_rms, 10) + " " + unit + " over " +
        std::to_string(report.replay_residuals) + " samples, against the fit's " +
        Num(fit.residual_rms(), 10) + " " + unit + ".\n\n";
  return md + AdequacySection(report) + NuisanceSection(report);
}

std::string TruthSection(const FitReport& report) {
  const Campaign& campaign = *report.campaign;
  if (campaign.truth.empty()) return "";
  std::string md = "### Against the truth the data were generated with\n\n";
  MarkdownTable table({"parameter", "truth", "estimate", "relative error", "error / standard error",
                       "truth inside the 95 % interval"});
  int known = 0, inside = 0;
  for (const ParameterEstimate& e : report.fit.estimates()) {
    const TruthCheck check = CheckTruth(campaign, e);
    if (!check.known) continue;
    ++known;
    inside += check.inside;
    table.Row({FitParameterName(e.parameter()), Num(check.truth, 8), Num(e.value(), 8),
               Num((e.value() - check.truth) / check.truth, 3),
               Num((e.value() - check.truth) / e.standard_error(), 3),
               check.inside ? "yes" : "**no**"});
  }
  if (known == 0) return "";
  md += table.str() + "\n";
  md += "The 95 % intervals contain the truth for " + std::to_string(inside) + " of " +
        std::to_string(known) + " parameters.";
  if (inside < known) {
    md +=
        " **The fit misses the truth** by more than its intervals allow. A 95 % interval misses "
        "the truth in one fit of twenty by design; more often, or by far, means something the "
        "model does not describe (docs/analysis.md, \"Limitations\").";
  }
  md += "\n\n";
  return md;
}

std::string CorrelationSection(const FitReport& report) {
  const FitResult& fit = report.fit;
  const int p = fit.estimates_size();
  std::vector<std::string> header{""};
  for (const auto& e : fit.estimates()) header.push_back(FitParameterName(e.parameter()));
  MarkdownTable table(header);
  for (int a = 0; a < p; ++a) {
    std::vector<std::string> row{FitParameterName(fit.estimates(a).parameter())};
    for (int b = 0; b < p; ++b) row.push_back(Num(fit.correlation(a * p + b), 4));
    table.Row(row);
  }
  std::string weakest;
  for (int k = 0; k < fit.weakest_combination_size(); ++k) {
    weakest += std::string(k ? ", " : "") + FitParameterName(fit.estimates(k).parameter()) + " " +
               Num(fit.weakest_combination(k), 3);
  }
  return "## Correlations and conditioning\n\n" + table.str() +
         "\nCondition number of the "
         "Jacobian with relative columns: " +
         Num(fit.condition_number(), 4) +
         " (above 1e8 the fit is ill-conditioned). The combination of relative parameter changes "
         "the data constrain least: (" +
         weakest + ").\n\n";
}

std::string VerdictSection(const FitReport& report) {
  const FitResult& fit = report.fit;
  std::string md = "## Verdict\n\n";
  md += fit.identified()  ? "Every free parameter is identified: the model explains every set to "
                            "its noise, each 95 % half-width is below half its value, its "
                            "correlations with the others below 0.99 and the condition number "
                            "below 1e8.\n\n"
        : !fit.adequate() ? "**Nothing is identified: the model does not explain the data** "
                            "(a wrong profile, a wrong declared load, an effect the model "
                            "lacks); the estimates describe the best wrong model.\n\n"
                          : "**Not every free parameter is identified**; the estimates marked "
                            "\"not identified\" are not determined by these data.\n\n";
  for (const std::string& note : fit.notes()) md += "- " + note + "\n";
  int missed = 0, known = 0;
  for (const ParameterEstimate& e : fit.estimates()) {
    const TruthCheck check = CheckTruth(*report.campaign, e);
    known += check.known;
    missed += check.known && !check.inside;
  }
  if (missed > 0) {
    md += "- \"identified\" speaks of precision, not accuracy: " + std::to_string(missed) + " of " +
          std::to_string(known) +
          " estimates miss the truth the data were generated with (above).\n";
  }
  md += "\n### Rig compliance from the reversal slopes\n\n";
  if (report.campaign->channel == mdr::analysis::LoopChannel::kTorsional) {
    return md +
           "Not computed for a torsional campaign: the fit identifies the shaft's compliance "
           "(rig_compliance) itself.\n\n";
  }
  if (!fit.has_guessed_rig_compliance()) {
    return md +
           "Not computed: it needs loop sets at two or more normal forces and a power-law "
           "profile (sphere, cone, power law).\n\n";
  }
  md +=
      "The practitioners' estimate, the intercept of 1/k against P^(-1/(n+1)) over the sets' "
      "apparent stiffness after the reversals: C_t = " +
      Num(fit.guessed_rig_compliance(), 4) + " m/N";
  if (fit.guessed_rig_compliance_error() > 0) {
    md += " (standard error " + Num(fit.guessed_rig_compliance_error(), 3) + " m/N)";
  }
  for (const ParameterEstimate& e : fit.estimates()) {
    if (e.parameter() == mdr::v1::FIT_PARAMETER_RIG_COMPLIANCE) {
      md += ", against the fitted " + Num(e.value(), 4) + " m/N";
    }
  }
  return md +
         ". Its chords lie below the full-stick stiffness, so it is a starting point, not "
         "an estimate.\n\n";
}

std::string SetsSection(const FitReport& report) {
  const ChannelLabels labels = CampaignLabels(*report.campaign);
  std::string md = "## Loop sets: figures per cycle\n\n";
  md += "Each set analysed with the fitted scene: the regimes against the fitted scene's " +
        std::string(labels.torsional ? "full-slip moment" : "onset of gross slip") +
        " at the set's load, the contact figures (" + labels.position_amplitude +
        "_c, A_c, B_c) with the fitted rig compliance. " + MeasuresNote(labels) + "\n\n";
  for (const ReportSet& set : report.sets) {
    md += "### " + Code(set.label) + " at P = " + Num(set.normal_force) + " N\n\n";
    md += AnalysisSummary(set.analysis, labels) +
          " Replay residual RMS over its counted samples: " + Num(set.replay_rms) + " " +
          labels.force_unit + ".\n\n";
    md += CycleTable(set.analysis, labels) + "\n";
  }
  return md;
}

// A torsional campaign has no fretting map (report.map_skipped says why): each set's moment
// amplitude against the fitted scene's full-slip moment at its load instead.
std::string FullSlipSection(const FitReport& report) {
  std::string md = "## No fretting map: the full-slip moments of the fitted scene\n\n" +
                   report.map_skipped +
                   "\n\nEach set's moment amplitude against the fitted "
                   "scene's full-slip moment at its load:\n\n";
  MarkdownTable table(
      {"file", "P [N]", "M* [N m] (contact)", "M_slip [N m]", "M* / M_slip", "regimes"});
  for (const ReportSet& set : report.sets) {
    double amplitude = 0, slip = std::nan("");
    for (const CycleFigures& c : set.analysis.cycles()) {
      amplitude += c.force_amplitude();
      slip = c.full_slip_moment();
    }
    amplitude /= std::max(1, set.analysis.cycles_size());
    table.Row({Code(set.label), Num(set.normal_force), Num(amplitude), Num(slip),
               Num(amplitude / slip, 4), RegimeCounts(set.analysis)});
  }
  return md + table.str() + "\n";
}

std::string MapSection(const FitReport& report) {
  if (!report.map_skipped.empty()) return FullSlipSection(report);
  std::string md = "## Fretting map of the fitted scene\n\n";
  md +=
      "At each load, the onset of gross slip (Q* = mu P) through the rig, and the exact loops "
      "at actuator amplitudes relative to the onset's (";
  for (int i = 0; i < report.map_request.relative_amplitudes_size(); ++i) {
    md += (i ? ", " : "") + Num(report.map_request.relative_amplitudes(i), 4);
  }
  md += "): partial slip below the onset, gross slip above it.\n\n";
  MarkdownTable table({"P [N]", "onset actuator amplitude [m] (contact+rig)",
                       "onset contact amplitude [m] (contact)", "Q* [N]",
                       "A at onset (contact+rig)", "A_c at onset (contact)", "C at onset (contact)",
                       "partial / gross loops"});
  for (const auto& load : report.map.loads()) {
    int partial = 0, gross = 0;
    for (int r : load.regimes()) {
      partial += r == mdr::v1::REGIME_PARTIAL_SLIP;
      gross += r == mdr::v1::REGIME_GROSS_SLIP;
    }
    const auto& onset = load.onset();
    table.Row({Num(onset.normal_force()), Num(onset.actuator_amplitude()),
               Num(onset.contact_amplitude()), Num(onset.force_amplitude()),
               Num(onset.energy_ratio(), 4), Num(onset.contact_energy_ratio(), 4),
               Num(onset.system_free_ratio(), 4),
               std::to_string(partial) + " / " + std::to_string(gross)});
  }
  md += table.str() +
        "\nThe measured cycles on the map (their actuator amplitude delta* over "
        "the onset's at their load, and their regime):\n\n";
  MarkdownTable placed({"file", "P [N]", "delta* [m]", "delta* / onset", "regimes"});
  for (const ReportSet& set : report.sets) {
    double onset = std::nan("");
    for (const auto& load : report.map.loads()) {
      if (load.onset().normal_force() == set.normal_force)
        onset = load.onset().actuator_amplitude();
    }
    double amplitude = 0;
    for (const CycleFigures& c : set.analysis.cycles()) amplitude += c.displacement_amplitude();
    amplitude /= std::max(1, set.analysis.cycles_size());
    placed.Row({Code(set.label), Num(set.normal_force), Num(amplitude), Num(amplitude / onset, 4),
                RegimeCounts(set.analysis)});
  }
  return md + placed.str() + "\n";
}

void WriteSetJson(const ReportSet& set, bool fit, JsonWriter* json) {
  json->BeginObject().Key("file").String(set.label).Key("path").String(set.csv.path);
  if (set.csv.run) {  // one run of a file of several: its id as written, its first and last line
    json->Key("run").String(*set.csv.run);
    json->Key("first_line").Number(static_cast<double>(set.csv.lines.front()));
    json->Key("last_line").Number(static_cast<double>(set.csv.lines.back()));
  }
  json->Key("normal_force").Number(set.normal_force);
  json->Key("samples").Number(static_cast<double>(set.csv.lines.size()));
  json->Key("synthetic");
  if (set.csv.synthetic) {
    json->String(*set.csv.synthetic);
  } else {
    json->Bool(false);
  }
  json->Key("layout");
  WriteLayout(set.layout, json);
  if (fit) {
    json->Key("first_counted_sample").Number(static_cast<double>(set.first_counted));
    json->Key("replay_residual_rms").Number(set.replay_rms);
  }
  json->Key("analysis").Message(Untimed(set.analysis));
  json->EndObject();
}

void WritePlotsJson(const Plots& plots, JsonWriter* json) {
  json->Key("plots").BeginArray();
  for (const std::string& png : plots.pngs) json->String(png);
  json->EndArray();
  json->Key("plots_skipped").String(plots.skipped);
}

}  // namespace

std::string LoopsMarkdown(const LoopsReport& report) {
  const ReportSet& first = report.sets.front();
  const ChannelLabels labels = SetLabels(first);
  std::string md = "# Loop analysis of " + Code(report.label) + "\n\n";
  if (first.csv.synthetic) {
    md += "> **Synthetic input**: " + Code(*first.csv.synthetic) + "\n\n";
  }
  std::size_t samples = 0;
  for (const ReportSet& set : report.sets) samples += set.csv.lines.size();
  md += "Columns: " + LayoutText(first.layout) + "; " + std::to_string(samples) + " samples";
  md += report.run_column.empty()
            ? "."
            : " in " + std::to_string(report.sets.size()) + " runs by the run column " +
                  Code(report.run_column) + ", each analysed on its own.";
  if (report.options.has_normal_force()) {
    md += " Normal force " + Num(report.options.normal_force()) + " N (given).";
  }
  if (report.options.has_rig_compliance()) {
    md += " Rig compliance " + Num(report.options.rig_compliance()) + " " + labels.compliance_unit +
          ": the contact figures (" + labels.position_amplitude + "_c, A_c, B_c) are " +
          (labels.torsional ? "phi - C M's (through the shaft)." : "u - C_t F_x's.");
  }
  if (!report.scene_source.empty()) {
    md += (labels.torsional ? " Regimes against the full-slip moment of the scene "
                            : " Regimes against the onset of gross slip of the scene ") +
          Code(report.scene_source) + ".";
  }
  std::vector<std::string> captions;
  if (report.run_column.empty()) {
    md += "\n\n" + AnalysisSummary(first.analysis, labels) + "\n\n" + MeasuresNote(labels) +
          "\n\n" + CycleTable(first.analysis, labels) + "\n";
    captions = {"the measured loop, coloured by cycle", "the figures per cycle"};
  } else {
    md += "\n\n" + MeasuresNote(labels) + "\n\n";
    for (const ReportSet& set : report.sets) {
      const std::string run = "run " + Code(Printable(*set.csv.run));
      md += "## Run " + Code(Printable(*set.csv.run)) + "\n\n" +
            std::to_string(set.csv.lines.size()) + " samples, " +
            (set.csv.format == RigFormat::kMat ? "elements " : "lines ") +
            std::to_string(set.csv.lines.front()) + " to " + std::to_string(set.csv.lines.back()) +
            ". " + AnalysisSummary(set.analysis, labels) + "\n\n" +
            CycleTable(set.analysis, labels) + "\n";
      captions.push_back(run + ": the measured loop, coloured by cycle");
      captions.push_back(run + ": the figures per cycle");
    }
  }
  return md + PlotsSection(report.plots, captions);
}

std::string LoopsJson(const LoopsReport& report) {
  JsonWriter json;
  json.BeginObject().Key("report").String("mdrctl loops");
  json.Key("options").Message(report.options);
  json.Key("scene").String(report.scene_source);
  if (report.run_column.empty()) {
    json.Key("set");
    WriteSetJson(report.sets.front(), false, &json);
  } else {
    json.Key("run_column").String(report.run_column);
    json.Key("runs").BeginArray();
    for (const ReportSet& set : report.sets) WriteSetJson(set, false, &json);
    json.EndArray();
  }
  WritePlotsJson(report.plots, &json);
  json.EndObject();
  return json.Pretty();
}

std::string FitMarkdown(const FitReport& report) {
  const Campaign& campaign = *report.campaign;
  std::string md = "# " +
                   (campaign.title.empty() ? "Fit of " + Code(campaign.path) : campaign.title) +
                   "\n\nCampaign " + Code(campaign.path) + ", fitted by `mdrctl fit`.\n\n";
  md += SyntheticSection(report.sets) + FittedSection(report) + EstimatesSection(report) +
        TruthSection(report) + CorrelationSection(report) + VerdictSection(report) +
        SetsSection(report) + MapSection(report);
  return md + PlotsSection(report.plots,
                           {"measured and fitted loops per set",
                            "residuals (measured - fitted) per set, with the " +
                                CampaignLabels(campaign).force_word + " noise",
                            "fretting map: Q*/P against the actuator amplitude, with the onsets "
                            "and the measured cycles",
                            "regimes: the boundary, the map's loops and the measured cycles"});
}

std::string FitJson(const FitReport& report) {
  const Campaign& campaign = *report.campaign;
  JsonWriter json;
  json.BeginObject().Key("report").String("mdrctl fit");
  json.Key("campaign").String(campaign.path).Key("title").String(campaign.title);
  json.Key("scene_source").String(campaign.scene_source);
  json.Key("request").Message(report.request);
  mdr::v1::FitResult fit = report.fit;
  fit.clear_compute_seconds();
  fit.clear_models();  // drawn in loops.png and residuals.png; from the API when needed
  json.Key("fit").Message(fit);
  json.Key("estimates").BeginArray();
  for (const ParameterEstimate& e : report.fit.estimates()) {
    json.BeginObject().Key("parameter").String(FitParameterName(e.parameter()));
    json.Key("value").Number(e.value()).Key("standard_error").Number(e.standard_error());
    json.Key("lower_95").Number(e.lower_95()).Key("upper_95").Number(e.upper_95());
    json.Key("identified").Bool(e.identified());
    if (const TruthCheck check = CheckTruth(campaign, e); check.known) {
      json.Key("truth").Number(check.truth).Key("truth_inside_95").Bool(check.inside);
    }
    json.EndObject();
  }
  json.EndArray();
  json.Key("replay").BeginObject();
  json.Key("residual_rms").Number(report.replay_rms);
  json.Key("residuals").Number(static_cast<double>(report.replay_residuals));
  json.Key("fit_residual_rms").Number(report.fit.residual_rms());
  json.Key("largest_contact_force_difference").Number(report.replay_difference);
  json.EndObject();
  json.Key("sets").BeginArray();
  for (const ReportSet& set : report.sets) WriteSetJson(set, true, &json);
  json.EndArray();
  if (report.fit.fitted_scene().has_torsion()) {
    json.Key("fitted_torsion").BeginObject();
    json.Key("torsional_modulus").Number(report.fitted_torsional_modulus);
    json.Key("rig_compliance").Number(report.fit.fitted_scene().torsion().rig_compliance());
    json.EndObject();
  }
  if (!report.map_skipped.empty()) {
    json.Key("fretting_map_skipped").String(report.map_skipped);
    WritePlotsJson(report.plots, &json);
    json.EndObject();
    return json.Pretty();
  }
  mdr::v1::FrettingMapResponse map = report.map;
  map.clear_compute_seconds();
  json.Key("fretting_map").BeginObject();
  json.Key("normal_forces")
      .Numbers(
          {report.map_request.normal_forces().begin(), report.map_request.normal_forces().end()});
  json.Key("relative_amplitudes")
      .Numbers({report.map_request.relative_amplitudes().begin(),
                report.map_request.relative_amplitudes().end()});
  json.Key("response").Message(map);
  json.EndObject();
  WritePlotsJson(report.plots, &json);
  json.EndObject();
  return json.Pretty();
}

}  // namespace mdrctl
