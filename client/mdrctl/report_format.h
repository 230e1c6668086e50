// Output of mdrctl: a run report, or any response message, as a readable table, CSV or JSON.
#pragma once

#include <google/protobuf/message.h>

#include <cstdio>
#include <string>
#include <vector>

#include "mdr/v1/contact_service.pb.h"
#include "mdr/v1/scene_file.pb.h"

namespace mdrctl {

enum class Format { kTable, kCsv, kJson };

// The proto3 JSON of a message (field names as in the .proto), indented.
std::string ToJson(const google::protobuf::Message& message);

// Steps (the file's outputs as columns), energy per cycle and recorded profiles.
void PrintReport(const mdr::v1::RunReport& report, const mdr::v1::SceneFile& file, Format format,
                 std::FILE* out);
// The per-step states of an Apply (table and CSV: one row per step), or the JSON.
void PrintApplyResponse(const mdr::v1::ApplyResponse& response, Format format, std::FILE* out);
// Sessions one per row (table, CSV) or as a JSON list.
void PrintSessions(const std::vector<mdr::v1::Session>& sessions, Format format, std::FILE* out);
// Any message: table and CSV list every set field as "path value"; JSON as ToJson.
void PrintMessage(const google::protobuf::Message& message, Format format, std::FILE* out);

}  // namespace mdrctl
