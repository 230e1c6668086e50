#include "mdr/bridge/scene_file.h"

#include <google/protobuf/util/json_util.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <cctype>
#include <fstream>
#include <regex>
#include <sstream>

namespace mdr::bridge {
namespace {

// "normalForce" -> "normal_force": the proto field name the parser and the server report.
std::string SnakeCase(const std::string& key) {
  std::string snake;
  for (char c : key) {
    if (std::isupper(static_cast<unsigned char>(c))) {
      snake += '_';
      snake += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else {
      snake += c;
    }
  }
  return snake;
}

// A plain (unquoted) YAML scalar as a JSON value: numbers, booleans and null as such, YAML's
// .inf/.nan as proto3 JSON's "Infinity"/"NaN", anything else (enum names) as a string.
std::string PlainScalarToJson(const std::string& value) {
  static const std::regex kJsonNumber(R"(-?(0|[1-9][0-9]*)(\.[0-9]+)?([eE][+-]?[0-9]+)?)");
  static const std::regex kYamlNumber(R"([-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?)");
  if (std::regex_match(value, kJsonNumber)) return value;
  if (std::regex_match(value, kYamlNumber)) {
    char number[32];
    std::snprintf(number, sizeof number, "%.17g", std::strtod(value.c_str(), nullptr));
    return number;
  }
  if (value == "true" || value == "false" || value == "null") return value;
  if (value == "~") return "null";
  if (value == ".inf" || value == "+.inf" || value == ".Inf") return "\"Infinity\"";
  if (value == "-.inf" || value == "-.Inf") return "\"-Infinity\"";
  if (value == ".nan" || value == ".NaN") return "\"NaN\"";
  return JsonQuoted(value);
}

class JsonEmitter {
 public:
  explicit JsonEmitter(std::map<std::string, int>* lines) : lines_(lines) {}

  void Emit(const YAML::Node& node, const std::string& path) {
    switch (node.Type()) {
      case YAML::NodeType::Map:
        EmitMap(node, path);
        break;
      case YAML::NodeType::Sequence:
        EmitSequence(node, path);
        break;
      case YAML::NodeType::Scalar:
        // A quoted scalar has the non-specific tag "!": always a string.
        json_ += node.Tag() == "!" ? JsonQuoted(node.Scalar()) : PlainScalarToJson(node.Scalar());
        break;
      default:
        json_ += "null";
    }
  }
  const std::string& json() const { return json_; }

 private:
  void Record(const std::string& path, const YAML::Mark& mark) {
    if (!path.empty() && mark.line >= 0) lines_->emplace(path, mark.line + 1);
  }
  void EmitMap(const YAML::Node& node, const std::string& path) {
    json_ += '{';
    bool first = true;
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      const std::string child = path.empty() ? SnakeCase(key) : path + "." + SnakeCase(key);
      Record(child, entry.first.Mark());
      if (!first) json_ += ',';
      first = false;
      json_ += JsonQuoted(key) + ':';
      Emit(entry.second, child);
    }
    json_ += '}';
  }
  void EmitSequence(const YAML::Node& node, const std::string& path) {
    json_ += '[';
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string child = path + "[" + std::to_string(i) + "]";
      Record(child, node[i].Mark());
      if (i > 0) json_ += ',';
      Emit(node[i], child);
    }
    json_ += ']';
  }

  std::map<std::string, int>* lines_;
  std::string json_;
};

// Splits protobuf's "(path) name: message" / "(path): message" into field and message.
Status ParserError(const std::string& error) {
  static const std::regex kLocated(R"(^\(([^)]*)\)(?: ([^:]+))?: (.*)$)");
  std::smatch match;
  if (!std::regex_match(error, match, kLocated)) return InvalidArgument("", error);
  std::string field = match[1];
  if (match[2].matched && !field.empty()) field.push_back('.');
  if (match[2].matched) field.append(match[2].str());
  return InvalidArgument(field, match[3]);
}

}  // namespace

Status ParseJsonMessage(const std::string& json, google::protobuf::Message* message) {
  const auto status = google::protobuf::util::JsonStringToMessage(json, message);
  if (status.ok()) return OkStatus();
  return ParserError(std::string(status.message()));
}

std::string DescribeYamlError(const YAML::Exception& error) {
  const auto* deep = dynamic_cast<const YAML::DeepRecursion*>(&error);
  return "line " + std::to_string(error.mark.line + 1) + ", column " +
         std::to_string(error.mark.column + 1) + ": " +
         (deep != nullptr ? "nested too deep for the YAML parser (it stops at depth " +
                                std::to_string(deep->depth()) + ")"
                          : error.msg);
}

Result<std::string> YamlToJson(const std::string& text, std::map<std::string, int>* lines) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    return InvalidArgument("", DescribeYamlError(e));
  }
  if (!root.IsMap())
    return InvalidArgument("", "must be a mapping of fields (YAML or a JSON object)");
  JsonEmitter emitter(lines);
  emitter.Emit(root, "");
  return emitter.json();
}

Status ParseYamlMessage(const std::string& text, google::protobuf::Message* message) {
  std::map<std::string, int> lines;
  auto json = YamlToJson(text, &lines);
  if (!json.ok()) return json.status();
  return ParseJsonMessage(*json, message);
}

Result<SceneDocument> SceneDocument::Load(const std::string& path) {
  std::ifstream in(path);
  if (!in) return InvalidArgument("", path + ": cannot open the scene file");
  std::stringstream text;
  text << in.rdbuf();
  return Parse(text.str(), path);
}

Result<SceneDocument> SceneDocument::Parse(const std::string& text, const std::string& name) {
  SceneDocument document;
  document.name_ = name;
  auto json = YamlToJson(text, &document.lines_);
  // A syntax error is the document's, not a field's: the field stays empty and the message
  // names the document and the line.
  if (!json.ok()) return InvalidArgument("", name + ": " + std::string(json.status().message()));
  const Status parsed = ParseJsonMessage(*json, &document.file_);
  if (!parsed.ok()) return document.Error(parsed.field(), parsed.message());
  return document;
}

std::string SceneDocument::Where(const std::string& field) const {
  std::string prefix = field;
  while (!prefix.empty()) {
    const auto found = lines_.find(prefix);
    if (found != lines_.end()) return name_ + ":" + std::to_string(found->second);
    const std::size_t cut = prefix.find_last_of(".[");
    prefix = cut == std::string::npos ? "" : prefix.substr(0, cut);
  }
  return name_;
}

Status SceneDocument::Error(const std::string& field, const std::string& message) const {
  return InvalidArgument(field, message + " (" + Where(field) + ")");
}

std::string JsonQuoted(std::string_view text) {
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') {
      quoted += '\\';
      quoted += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\u%04x", static_cast<unsigned char>(c));
      quoted += escaped;
    } else {
      quoted += c;
    }
  }
  return quoted + "\"";
}

}  // namespace mdr::bridge
