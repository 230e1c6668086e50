// A small JSON writer for mdrctl's reports: objects, arrays, strings, numbers (non-finite ones as
// null) and embedded proto3 JSON; Pretty() indents the result by two spaces.
#pragma once

#include <google/protobuf/message.h>

#include <string>
#include <string_view>
#include <vector>

#include "mdr/bridge/scene_file.h"

namespace mdrctl {

class JsonWriter {
 public:
  JsonWriter& BeginObject();
  JsonWriter& EndObject();
  JsonWriter& BeginArray();
  JsonWriter& EndArray();
  // The key of the next value in an object.
  JsonWriter& Key(std::string_view key);
  JsonWriter& String(std::string_view value);
  JsonWriter& Number(double value);
  JsonWriter& Bool(bool value);
  // A message as proto3 JSON (field names as in the .proto).
  JsonWriter& Message(const google::protobuf::Message& message);
  JsonWriter& Numbers(const std::vector<double>& values);

  // The document, indented.
  std::string Pretty() const;

 private:
  void BeforeValue();
  std::string json_;
  std::vector<bool> first_;  // per open container: no value written yet
  bool after_key_ = false;
};

using mdr::bridge::JsonQuoted;  // a JSON string literal (mdr/bridge/scene_file.h)

// A message as proto3 JSON the way every mdrctl output writes it (--format json, report.json):
// field names as in the .proto, and every field present, zeros, false and empty lists included,
// so that a script reads a field without knowing proto3's defaults. Indented or compact.
// JsonFields::kSet leaves the defaults out, for a file a person reads and edits (the scene of a
// campaign that synthesize writes).
enum class JsonFields { kEvery, kSet };
std::string ProtoJson(const google::protobuf::Message& message, bool indented,
                      JsonFields fields = JsonFields::kEvery);

}  // namespace mdrctl
