#include "campaign.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <string_view>

#include "mdr/base/validate.h"
#include "mdr/bridge/scene_file.h"

namespace mdrctl {
namespace {

namespace fs = std::filesystem;
using mdr::v1::FitLoopsRequest;
using mdr::v1::FitParameter;

constexpr FitParameter kFitParameters[] = {mdr::v1::FIT_PARAMETER_FRICTION,
                                           mdr::v1::FIT_PARAMETER_EFFECTIVE_MODULUS,
                                           mdr::v1::FIT_PARAMETER_PROFILE_SCALE,
                                           mdr::v1::FIT_PARAMETER_RIG_COMPLIANCE,
                                           mdr::v1::FIT_PARAMETER_DISPLACEMENT_OFFSET,
                                           mdr::v1::FIT_PARAMETER_TORSIONAL_MODULUS};

using mdr::analysis::LoopChannel;

// The column and unit keys of one channel only: a campaign reads the pair its scene asks for.
struct ChannelKeys {
  std::vector<std::string_view> columns, units;
};
ChannelKeys OwnKeys(LoopChannel channel) {
  if (channel == LoopChannel::kTorsional)
    return {{"twist", "twisting_moment"}, {"twist", "moment"}};
  return {{"displacement", "tangential_force"}, {"displacement"}};
}
LoopChannel Other(LoopChannel channel) {
  return channel == LoopChannel::kTorsional ? LoopChannel::kTangential : LoopChannel::kTorsional;
}

// A parsed YAML file with the line of every field, and typed readers whose errors point at it.
class YamlDoc {
 public:
  static mdr::Result<YamlDoc> Load(const std::string& path) {
    YamlDoc doc;
    doc.lines_ = FieldLines(path);
    try {
      doc.root_ = YAML::LoadFile(path);
    } catch (const YAML::BadFile&) {
      return mdr::InvalidArgument("", path + ": cannot open the campaign file");
    } catch (const YAML::Exception& e) {
      // The document's error, not a field's (as for scene files): the message names the file.
      return mdr::InvalidArgument("", path + ": " + mdr::bridge::DescribeYamlError(e));
    }
    if (!doc.root_.IsMap()) {
      return mdr::InvalidArgument("", path + ": must be a YAML mapping of fields");
    }
    doc.RecordLines(doc.root_, "");
    return doc;
  }

  const YAML::Node& root() const { return root_; }
  const FieldLines& lines() const { return lines_; }
  mdr::Status Error(const std::string& field, const std::string& message) const {
    return lines_.Error(field, message);
  }
  // `file` relative to this file's directory (absolute paths pass).
  std::string Resolve(const std::string& file) const {
    const fs::path relative(file);
    if (relative.is_absolute()) return file;
    return (fs::path(lines_.file()).parent_path() / relative).lexically_normal().string();
  }

  // Every key of the mapping must be one of `known`.
  mdr::Status CheckKeys(const YAML::Node& map, const std::string& field,
                        const std::vector<std::string_view>& known) const {
    if (!map.IsMap()) return Error(field, "must be a mapping");
    for (const auto& entry : map) {
      const std::string key = entry.first.Scalar();
      bool found = false;
      for (std::string_view k : known) found = found || k == key;
      if (!found) {
        std::string names;
        for (std::string_view k : known) names += (names.empty() ? "" : ", ") + std::string(k);
        // A key that is not a plain name is quoted, escaped, in the message instead.
        const bool plain =
            !key.empty() && key.size() <= 64 && std::all_of(key.begin(), key.end(), [](char c) {
              return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
            });
        return plain ? Error(Join(field, key), "unknown key; the keys here are " + names)
                     : mdr::InvalidArgument(field, "unknown key " + Printable(key) +
                                                       "; the keys here are " + names + " (" +
                                                       lines_.Where(Join(field, key)) + ")");
      }
    }
    return mdr::OkStatus();
  }

  mdr::Result<double> Number(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) return Error(field, "must be a number");
    std::string_view text = node.Scalar();
    if (text.starts_with('+')) text.remove_prefix(1);
    double value = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
      return Error(field, "must be a finite number, got " + Printable(node.Scalar()));
    }
    return value;
  }
  mdr::Result<double> Positive(const YAML::Node& node, const std::string& field) const {
    auto value = Number(node, field);
    if (value.ok() && !(*value > 0)) {
      return Error(field, "must be > 0, got " + mdr::FormatNumber(*value));
    }
    return value;
  }
  mdr::Result<double> NonNegative(const YAML::Node& node, const std::string& field) const {
    auto value = Number(node, field);
    if (value.ok() && !(*value >= 0)) {
      return Error(field, "must be >= 0, got " + mdr::FormatNumber(*value));
    }
    return value;
  }
  mdr::Result<int> Integer(const YAML::Node& node, const std::string& field, int lo, int hi) const {
    auto value = Number(node, field);
    if (!value.ok()) return value.status();
    if (*value != std::floor(*value) || *value < lo || *value > hi) {
      return Error(field, "must be an integer in [" + std::to_string(lo) + ", " +
                              std::to_string(hi) + "], got " + mdr::FormatNumber(*value));
    }
    return static_cast<int>(*value);
  }
  mdr::Result<bool> Bool(const YAML::Node& node, const std::string& field) const {
    if (node.IsScalar()) {
      if (node.Scalar() == "true") return true;
      if (node.Scalar() == "false") return false;
    }
    return Error(field, "must be true or false");
  }
  mdr::Result<std::string> String(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) return Error(field, "must be a string");
    return node.Scalar();
  }
  // A non-empty list of numbers > 0.
  mdr::Result<std::vector<double>> PositiveList(const YAML::Node& node,
                                                const std::string& field) const {
    if (!node.IsSequence() || node.size() == 0) return Error(field, "must be a non-empty list");
    std::vector<double> values;
    for (std::size_t i = 0; i < node.size(); ++i) {
      auto value = Positive(node[i], mdr::Indexed(field, i));
      if (!value.ok()) return value.status();
      values.push_back(*value);
    }
    return values;
  }

  // A scene file's path (relative to this file) or an inline mdr.v1.Scene.
  mdr::Status Scene(const YAML::Node& node, const std::string& field, mdr::v1::Scene* scene,
                    std::string* source) const {
    if (node.IsScalar()) {
      *source = Resolve(node.Scalar());
      auto document = mdr::bridge::SceneDocument::Load(*source);
      if (!document.ok()) return document.status();
      *scene = document->file().scene();
      return mdr::OkStatus();
    }
    if (!node.IsMap()) return Error(field, "must be a scene file's path or an inline scene");
    *source = "inline";
    const mdr::Status parsed = mdr::bridge::ParseYamlMessage(YAML::Dump(node), scene);
    if (!parsed.ok()) return Error(Join(field, parsed.field()), parsed.message());
    return mdr::OkStatus();
  }

  static std::string Join(const std::string& field, const std::string& key) {
    return field.empty() ? key : key.empty() ? field : field + "." + key;
  }

 private:
  void RecordLines(const YAML::Node& node, const std::string& path) {
    if (node.IsMap()) {
      for (const auto& entry : node) {
        const std::string child = Join(path, entry.first.Scalar());
        lines_.Record(child, entry.first.Mark().line + 1);
        RecordLines(entry.second, child);
      }
    } else if (node.IsSequence()) {
      for (std::size_t i = 0; i < node.size(); ++i) {
        const std::string child = mdr::Indexed(path, i);
        lines_.Record(child, node[i].Mark().line + 1);
        RecordLines(node[i], child);
      }
    }
  }

  YAML::Node root_;
  FieldLines lines_;
};

#define MDRCTL_ASSIGN(target, expression)                       \
  do {                                                          \
    auto assigned_value_ = (expression);                        \
    if (!assigned_value_.ok()) return assigned_value_.status(); \
    target = std::move(assigned_value_).value();                \
  } while (false)

// A key of the other channel's columns or units (`what`) is refused by name: a tangential
// campaign's scene has no torsion, a torsional one's reads twists and moments.
mdr::Status CheckChannelKeys(const YamlDoc& doc, const YAML::Node& map, const std::string& field,
                             LoopChannel channel, bool columns) {
  const ChannelKeys other = OwnKeys(Other(channel));
  for (std::string_view key : columns ? other.columns : other.units) {
    if (!map[std::string(key)]) continue;
    return doc.Error(
        YamlDoc::Join(field, std::string(key)),
        channel == LoopChannel::kTorsional
            ? "is a tangential record's; the campaign's scene has torsion, so its sets are read "
              "as torsional records (columns twist and twisting_moment, units twist and moment)"
            : "is a torsional record's; it needs a scene with torsion (scene.torsion), else the "
              "sets are tangential records (columns displacement and tangential_force)");
  }
  return mdr::OkStatus();
}

// `columns: {displacement, tangential_force | twist, twisting_moment, normal_force, time, run}`
// and `units: {displacement | twist, moment, force, time}` of `map` over `layout`, for the
// layout's channel.
mdr::Status ReadLayout(const YamlDoc& doc, const YAML::Node& map, const std::string& field,
                       CsvLayout* layout) {
  const std::string prefix = field.empty() ? "" : field + ".";
  if (const YAML::Node columns = map["columns"]) {
    const std::string f = prefix + "columns";
    if (auto s = doc.CheckKeys(columns, f,
                               {"displacement", "tangential_force", "twist", "twisting_moment",
                                "normal_force", "time", "run"});
        !s.ok()) {
      return s;
    }
    if (auto s = CheckChannelKeys(doc, columns, f, layout->channel, true); !s.ok()) return s;
    if (columns["displacement"])
      MDRCTL_ASSIGN(layout->displacement_column,
                    doc.String(columns["displacement"], f + ".displacement"));
    if (columns["tangential_force"])
      MDRCTL_ASSIGN(layout->force_column,
                    doc.String(columns["tangential_force"], f + ".tangential_force"));
    if (columns["twist"])
      MDRCTL_ASSIGN(layout->twist_column, doc.String(columns["twist"], f + ".twist"));
    if (columns["twisting_moment"])
      MDRCTL_ASSIGN(layout->moment_column,
                    doc.String(columns["twisting_moment"], f + ".twisting_moment"));
    if (columns["normal_force"])
      MDRCTL_ASSIGN(layout->normal_force_column,
                    doc.String(columns["normal_force"], f + ".normal_force"));
    if (columns["time"])
      MDRCTL_ASSIGN(layout->time_column, doc.String(columns["time"], f + ".time"));
    if (columns["run"]) MDRCTL_ASSIGN(layout->run_column, doc.String(columns["run"], f + ".run"));
  }
  if (const YAML::Node units = map["units"]) {
    const std::string f = prefix + "units";
    if (auto s = doc.CheckKeys(units, f, {"displacement", "force", "twist", "moment", "time"});
        !s.ok()) {
      return s;
    }
    if (auto s = CheckChannelKeys(doc, units, f, layout->channel, false); !s.ok()) return s;
    const auto unit = [&](const char* key, Quantity quantity, double* factor) -> mdr::Status {
      if (!units[key]) return mdr::OkStatus();
      auto name = doc.String(units[key], f + "." + key);
      if (!name.ok()) return name.status();
      auto value = UnitFactor(quantity, *name, f + "." + key);
      if (!value.ok()) return doc.Error(value.status().field(), value.status().message());
      *factor = *value;
      return mdr::OkStatus();
    };
    if (auto s = unit("displacement", Quantity::kDisplacement, &layout->displacement_unit); !s.ok())
      return s;
    if (auto s = unit("force", Quantity::kForce, &layout->force_unit); !s.ok()) return s;
    if (auto s = unit("time", Quantity::kTime, &layout->time_unit); !s.ok()) return s;
    if (auto s = unit("twist", Quantity::kTwist, &layout->twist_unit); !s.ok()) return s;
    if (auto s = unit("moment", Quantity::kMoment, &layout->moment_unit); !s.ok()) return s;
  }
  return mdr::OkStatus();
}

mdr::Result<FitParameter> ParameterByName(const YamlDoc& doc, const YAML::Node& node,
                                          const std::string& field) {
  auto name = doc.String(node, field);
  if (!name.ok()) return name.status();
  std::string names;
  for (FitParameter p : kFitParameters) {
    if (*name == FitParameterName(p)) return p;
    names += (names.empty() ? "" : ", ") + std::string(FitParameterName(p));
  }
  return doc.Error(field, "must be one of " + names + ", got " + Printable(*name));
}

mdr::Result<std::vector<FitLoopsRequest::FreeParameter>> ReadFree(const YamlDoc& doc,
                                                                  const YAML::Node& node,
                                                                  const std::string& field) {
  if (!node.IsSequence() || node.size() == 0) {
    return doc.Error(field, "must list the free parameters");
  }
  std::vector<FitLoopsRequest::FreeParameter> free;
  for (std::size_t k = 0; k < node.size(); ++k) {
    const std::string f = mdr::Indexed(field, k);
    const YAML::Node item = node[k];
    if (auto s = doc.CheckKeys(item, f, {"parameter", "initial", "lower", "upper"}); !s.ok()) {
      return s;
    }
    if (!item["parameter"] || !item["lower"] || !item["upper"]) {
      return doc.Error(f, "needs parameter, lower and upper (initial is optional)");
    }
    FitLoopsRequest::FreeParameter parameter;
    auto which = ParameterByName(doc, item["parameter"], f + ".parameter");
    if (!which.ok()) return which.status();
    parameter.set_parameter(*which);
    double value = 0;
    MDRCTL_ASSIGN(value, doc.Number(item["lower"], f + ".lower"));
    parameter.set_lower(value);
    MDRCTL_ASSIGN(value, doc.Number(item["upper"], f + ".upper"));
    parameter.set_upper(value);
    if (item["initial"]) {
      MDRCTL_ASSIGN(value, doc.Number(item["initial"], f + ".initial"));
      parameter.set_initial(value);
    }
    free.push_back(parameter);
  }
  return free;
}

// The fit options shared by campaigns and the fit section of a synthesis spec.
struct FitSection {
  std::vector<FitLoopsRequest::FreeParameter> free;
  FitLoopsRequest::Nuisances nuisances;
  std::optional<double> displacement_noise, force_noise;
  std::optional<int> burn_in_reversals;
  double reversal_threshold = 0;
  int max_iterations = 0;
  std::vector<double> map_normal_forces, map_relative_amplitudes;
};

mdr::Status ReadFitSection(const YamlDoc& doc, const YAML::Node& map, const std::string& field,
                           bool map_loads, FitSection* fit) {
  const auto f = [&](const char* key) { return YamlDoc::Join(field, key); };
  if (!map["free"]) return doc.Error(f("free"), "is required: the parameters to fit");
  MDRCTL_ASSIGN(fit->free, ReadFree(doc, map["free"], f("free")));
  if (const YAML::Node nuisances = map["nuisances"]) {
    const std::string n = f("nuisances");
    if (auto s = doc.CheckKeys(nuisances, n, {"force_offset", "displacement_drift", "moving_mass"});
        !s.ok()) {
      return s;
    }
    bool value = false;
    if (nuisances["force_offset"]) {
      MDRCTL_ASSIGN(value, doc.Bool(nuisances["force_offset"], n + ".force_offset"));
      fit->nuisances.set_force_offset(value);
    }
    if (nuisances["displacement_drift"]) {
      MDRCTL_ASSIGN(value, doc.Bool(nuisances["displacement_drift"], n + ".displacement_drift"));
      fit->nuisances.set_displacement_drift(value);
    }
    if (nuisances["moving_mass"]) {
      MDRCTL_ASSIGN(value, doc.Bool(nuisances["moving_mass"], n + ".moving_mass"));
      fit->nuisances.set_moving_mass(value);
    }
  }
  if (map["displacement_noise"]) {
    MDRCTL_ASSIGN(fit->displacement_noise,
                  doc.Positive(map["displacement_noise"], f("displacement_noise")));
  }
  if (map["force_noise"]) {
    MDRCTL_ASSIGN(fit->force_noise, doc.Positive(map["force_noise"], f("force_noise")));
  }
  if (map["burn_in_reversals"]) {
    MDRCTL_ASSIGN(fit->burn_in_reversals,
                  doc.Integer(map["burn_in_reversals"], f("burn_in_reversals"), 0, 1000000));
  }
  if (map["reversal_threshold"]) {
    MDRCTL_ASSIGN(fit->reversal_threshold,
                  doc.NonNegative(map["reversal_threshold"], f("reversal_threshold")));
  }
  if (map["max_iterations"]) {
    MDRCTL_ASSIGN(fit->max_iterations,
                  doc.Integer(map["max_iterations"], f("max_iterations"), 0, 1000));
  }
  if (const YAML::Node fretting = map["fretting_map"]) {
    const std::string m = f("fretting_map");
    std::vector<std::string_view> keys{"relative_amplitudes"};
    if (map_loads) keys.push_back("normal_forces");
    if (auto s = doc.CheckKeys(fretting, m, keys); !s.ok()) return s;
    if (fretting["normal_forces"]) {
      MDRCTL_ASSIGN(fit->map_normal_forces,
                    doc.PositiveList(fretting["normal_forces"], m + ".normal_forces"));
    }
    if (fretting["relative_amplitudes"]) {
      MDRCTL_ASSIGN(fit->map_relative_amplitudes,
                    doc.PositiveList(fretting["relative_amplitudes"], m + ".relative_amplitudes"));
    }
  }
  return mdr::OkStatus();
}

mdr::Result<std::vector<CampaignSet>> ReadSets(const YamlDoc& doc, const CsvLayout& defaults) {
  const YAML::Node sets = doc.root()["sets"];
  if (!sets || !sets.IsSequence() || sets.size() == 0) {
    return doc.Error("sets", "must list the loop sets ({file, normal_force?, run?})");
  }
  std::vector<CampaignSet> out;
  for (std::size_t i = 0; i < sets.size(); ++i) {
    const std::string f = mdr::Indexed("sets", i);
    const YAML::Node item = sets[i];
    if (auto s = doc.CheckKeys(item, f, {"file", "normal_force", "run", "columns", "units"});
        !s.ok()) {
      return s;
    }
    if (!item["file"]) return doc.Error(f, "needs file");
    CampaignSet set;
    MDRCTL_ASSIGN(set.file, doc.String(item["file"], f + ".file"));
    set.path = doc.Resolve(set.file);
    set.layout = defaults;
    if (auto s = ReadLayout(doc, item, f, &set.layout); !s.ok()) return s;
    if (item["normal_force"]) {
      MDRCTL_ASSIGN(set.normal_force, doc.Positive(item["normal_force"], f + ".normal_force"));
    } else if (set.layout.normal_force_column.empty()) {
      return doc.Error(f, "needs normal_force (N), or a normal_force column to replay");
    }
    if (item["run"]) {
      MDRCTL_ASSIGN(set.run, doc.String(item["run"], f + ".run"));
      if (set.layout.run_column.empty()) {
        return doc.Error(f + ".run",
                         "needs a run column to find it in: columns: {run: NAME}, for every set "
                         "or in this one");
      }
    }
    out.push_back(set);
  }
  return out;
}

mdr::Result<std::map<std::string, double>> ReadTruth(const YamlDoc& doc, const YAML::Node& node) {
  std::map<std::string, double> truth;
  if (auto s = doc.CheckKeys(node, "truth",
                             {"friction", "effective_modulus", "profile_scale", "rig_compliance",
                              "displacement_offset", "torsional_modulus"});
      !s.ok()) {
    return s;
  }
  for (const auto& entry : node) {
    const std::string key = entry.first.Scalar();
    MDRCTL_ASSIGN(truth[key], doc.Number(entry.second, "truth." + key));
  }
  return truth;
}

// `noise: {seed, displacement, force | force_relative}`, or for a torsional truth `{seed, twist,
// moment | moment_relative}` (rad and N m): the other channel's keys are refused by name.
mdr::Status ReadNoise(const YamlDoc& doc, const YAML::Node& noise, SynthesisSpec* spec) {
  const bool torsional = spec->truth.has_torsion();
  const std::string position = torsional ? "twist" : "displacement";
  const std::string force = torsional ? "moment" : "force";
  if (auto s = doc.CheckKeys(noise, "noise",
                             {"seed", "displacement", "force", "force_relative", "twist", "moment",
                              "moment_relative"});
      !s.ok()) {
    return s;
  }
  for (const char* key : torsional
                             ? std::vector<const char*>{"displacement", "force", "force_relative"}
                             : std::vector<const char*>{"twist", "moment", "moment_relative"}) {
    if (noise[key]) {
      return doc.Error(std::string("noise.") + key,
                       torsional ? "is a tangential record's; a torsional truth (scene.torsion) "
                                   "takes twist (rad), moment or moment_relative (N m)"
                                 : "is a torsional record's; it needs a truth with torsion");
    }
  }
  if (noise["seed"]) {
    double seed = 0;
    MDRCTL_ASSIGN(seed, doc.NonNegative(noise["seed"], "noise.seed"));
    if (seed != std::floor(seed) || seed > 9007199254740992.0) {
      return doc.Error("noise.seed", "must be an integer in [0, 2^53]");
    }
    spec->seed = static_cast<std::uint64_t>(seed);
  }
  if (noise[position]) {
    MDRCTL_ASSIGN(spec->displacement_noise, doc.NonNegative(noise[position], "noise." + position));
  }
  const std::string relative = force + "_relative";
  if (noise[force] && noise[relative]) {
    return doc.Error("noise." + force, "give " + force + " (" + (torsional ? "N m" : "N") +
                                           ") or " + relative + " (of " +
                                           (torsional ? "M*" : "Q*") + "), not both");
  }
  if (noise[force]) {
    MDRCTL_ASSIGN(spec->force_noise, doc.NonNegative(noise[force], "noise." + force));
  }
  if (noise[relative]) {
    MDRCTL_ASSIGN(spec->force_noise_relative,
                  doc.NonNegative(noise[relative], "noise." + relative));
  }
  return mdr::OkStatus();
}

}  // namespace

const char* FitParameterName(FitParameter parameter) {
  switch (parameter) {
    case mdr::v1::FIT_PARAMETER_FRICTION:
      return "friction";
    case mdr::v1::FIT_PARAMETER_EFFECTIVE_MODULUS:
      return "effective_modulus";
    case mdr::v1::FIT_PARAMETER_PROFILE_SCALE:
      return "profile_scale";
    case mdr::v1::FIT_PARAMETER_RIG_COMPLIANCE:
      return "rig_compliance";
    case mdr::v1::FIT_PARAMETER_DISPLACEMENT_OFFSET:
      return "displacement_offset";
    case mdr::v1::FIT_PARAMETER_TORSIONAL_MODULUS:
      return "torsional_modulus";
    default:
      return "unspecified";
  }
}

std::string FieldLines::Where(const std::string& field) const {
  std::string prefix = field;
  while (!prefix.empty()) {
    const auto found = lines_.find(prefix);
    if (found != lines_.end()) return file_ + ":" + std::to_string(found->second);
    const std::size_t cut = prefix.find_last_of(".[");
    prefix = cut == std::string::npos ? "" : prefix.substr(0, cut);
  }
  return file_;
}

mdr::Status FieldLines::Error(const std::string& field, const std::string& message) const {
  return mdr::InvalidArgument(field, message + " (" + Where(field) + ")");
}

std::vector<double> DefaultMapAmplitudes() {
  return {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.05, 1.25, 1.5, 2, 2.5, 3};
}

mdr::Result<Campaign> LoadCampaign(const std::string& path) {
  auto loaded = YamlDoc::Load(path);
  if (!loaded.ok()) return loaded.status();
  const YamlDoc& doc = *loaded;
  const YAML::Node& root = doc.root();
  if (auto s = doc.CheckKeys(
          root, "",
          {"title", "scene", "columns", "units", "sets", "free", "nuisances", "displacement_noise",
           "force_noise", "burn_in_reversals", "reversal_threshold", "max_iterations",
           "displacement_resolution", "fretting_map", "truth"});
      !s.ok()) {
    return s;
  }
  Campaign campaign;
  campaign.path = path;
  campaign.lines = doc.lines();
  if (root["title"]) MDRCTL_ASSIGN(campaign.title, doc.String(root["title"], "title"));
  if (!root["scene"]) return doc.Error("scene", "is required: a scene file's path or a scene");
  if (auto s = doc.Scene(root["scene"], "scene", &campaign.scene, &campaign.scene_source);
      !s.ok()) {
    return s;
  }
  if (campaign.scene.has_torsion()) campaign.channel = LoopChannel::kTorsional;
  CsvLayout defaults;
  defaults.channel = campaign.channel;
  if (auto s = ReadLayout(doc, root, "", &defaults); !s.ok()) return s;
  MDRCTL_ASSIGN(campaign.sets, ReadSets(doc, defaults));
  FitSection fit;
  if (auto s = ReadFitSection(doc, root, "", true, &fit); !s.ok()) return s;
  campaign.free = fit.free;
  campaign.nuisances = fit.nuisances;
  campaign.displacement_noise = fit.displacement_noise;
  campaign.force_noise = fit.force_noise;
  campaign.burn_in_reversals = fit.burn_in_reversals;
  campaign.reversal_threshold = fit.reversal_threshold;
  campaign.max_iterations = fit.max_iterations;
  campaign.map_normal_forces = fit.map_normal_forces;
  campaign.map_relative_amplitudes = fit.map_relative_amplitudes;
  if (root["displacement_resolution"]) {
    MDRCTL_ASSIGN(campaign.displacement_resolution,
                  doc.NonNegative(root["displacement_resolution"], "displacement_resolution"));
  }
  if (root["truth"]) MDRCTL_ASSIGN(campaign.truth, ReadTruth(doc, root["truth"]));
  return campaign;
}

mdr::Result<SynthesisSpec> LoadSynthesisSpec(const std::string& path) {
  auto loaded = YamlDoc::Load(path);
  if (!loaded.ok()) return loaded.status();
  const YamlDoc& doc = *loaded;
  const YAML::Node& root = doc.root();
  if (auto s = doc.CheckKeys(root, "",
                             {"title", "truth", "normal_forces", "amplitudes", "cycles",
                              "samples_per_cycle", "sampling_rate", "noise", "fit"});
      !s.ok()) {
    return s;
  }
  SynthesisSpec spec;
  spec.path = path;
  spec.lines = doc.lines();
  for (const char* key : {"truth", "normal_forces", "amplitudes", "cycles", "samples_per_cycle",
                          "sampling_rate", "fit"}) {
    if (!root[key]) return doc.Error(key, "is required");
  }
  if (root["title"]) MDRCTL_ASSIGN(spec.title, doc.String(root["title"], "title"));
  std::string source;
  if (auto s = doc.Scene(root["truth"], "truth", &spec.truth, &source); !s.ok()) return s;
  MDRCTL_ASSIGN(spec.normal_forces, doc.PositiveList(root["normal_forces"], "normal_forces"));
  MDRCTL_ASSIGN(spec.amplitudes, doc.PositiveList(root["amplitudes"], "amplitudes"));
  MDRCTL_ASSIGN(spec.cycles, doc.Integer(root["cycles"], "cycles", 2, 10000));
  // A multiple of 4 puts samples on the sine's extremes and zeros.
  MDRCTL_ASSIGN(spec.samples_per_cycle,
                doc.Integer(root["samples_per_cycle"], "samples_per_cycle", 8, 1000000));
  if (spec.samples_per_cycle % 4 != 0) {
    return doc.Error("samples_per_cycle",
                     "must be a multiple of 4 (samples on the extremes of the sine), got " +
                         std::to_string(spec.samples_per_cycle));
  }
  MDRCTL_ASSIGN(spec.sampling_rate, doc.Positive(root["sampling_rate"], "sampling_rate"));
  if (const YAML::Node noise = root["noise"]) {
    if (auto s = ReadNoise(doc, noise, &spec); !s.ok()) return s;
  }
  const YAML::Node fit_node = root["fit"];
  if (auto s = doc.CheckKeys(
          fit_node, "fit",
          {"free", "nuisances", "displacement_noise", "force_noise", "burn_in_reversals",
           "reversal_threshold", "max_iterations", "fretting_map"});
      !s.ok()) {
    return s;
  }
  FitSection fit;
  if (auto s = ReadFitSection(doc, fit_node, "fit", false, &fit); !s.ok()) return s;
  spec.free = fit.free;
  spec.nuisances = fit.nuisances;
  spec.fit_displacement_noise = fit.displacement_noise;
  spec.fit_force_noise = fit.force_noise;
  spec.burn_in_reversals = fit.burn_in_reversals;
  spec.reversal_threshold = fit.reversal_threshold;
  spec.max_iterations = fit.max_iterations;
  spec.map_relative_amplitudes = fit.map_relative_amplitudes;
  return spec;
}

}  // namespace mdrctl
