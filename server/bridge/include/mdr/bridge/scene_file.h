// Scene files (mdr.v1.SceneFile) in YAML or JSON. Both are read with yaml-cpp (JSON is YAML),
// converted to proto3 JSON and parsed by protobuf's JSON parser: the proto is the one schema.
// The document remembers the source line of every field so that any error, from the parser, the
// path rules or the server, points at the file and line.
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "mdr/base/status.h"
#include "mdr/v1/scene_file.pb.h"

namespace YAML {
class Exception;
}  // namespace YAML

namespace mdr::bridge {

// A JSON string literal of `text` (UTF-8 passes; '"', '\\' and control characters are escaped).
std::string JsonQuoted(std::string_view text);

class SceneDocument {
 public:
  // Reads and parses the file at `path`; errors name the file, the line and the field.
  static Result<SceneDocument> Load(const std::string& path);
  // Parses `text`; `name` stands for the file in messages.
  static Result<SceneDocument> Parse(const std::string& text, const std::string& name);

  const v1::SceneFile& file() const { return file_; }
  const std::string& name() const { return name_; }

  // "name:line" of `field` (a path such as "scene.sphere.radius" or "path[2].ramp.steps"), or of
  // the nearest enclosing field with a known line; "name" when none is known.
  std::string Where(const std::string& field) const;
  // The error "field: message (name:line)".
  Status Error(const std::string& field, const std::string& message) const;

 private:
  std::string name_;
  v1::SceneFile file_;
  // Field path (snake_case names, [i] for list items) -> 1-based line.
  std::map<std::string, int> lines_;
};

// "line N, column M: what" for an error of yaml-cpp's parser, which names its nesting limit (a
// file nested deeper than it parses) "bad file", as if the file could not be opened.
std::string DescribeYamlError(const YAML::Exception& error);

// Converts YAML (or JSON) text to proto3 JSON, recording the line of every field in *lines.
// Errors are INVALID_ARGUMENT with field "" and a message "line N, column M: ...".
Result<std::string> YamlToJson(const std::string& text, std::map<std::string, int>* lines);

// A message parsed from one YAML/JSON value such as "{normal_force: 100}" (for command lines).
Status ParseYamlMessage(const std::string& text, google::protobuf::Message* message);

// A message parsed from proto3 JSON as it is (no YAML: large sample arrays parse at protobuf's
// speed). Errors name the field protobuf's parser names ("sets[0].normal_force"), or none for a
// syntax error.
Status ParseJsonMessage(const std::string& json, google::protobuf::Message* message);

}  // namespace mdr::bridge
