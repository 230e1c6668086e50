// libFuzzer target for mdrctl's rig file readers (client/mdrctl/rig_csv.cc, rig_mat.cc) on
// arbitrary bytes, under bounds lowered so that fuzzed files reach them (lines of 48 bytes, 16
// samples). Checks: nothing crashes (ASan + UBSan); a CSV file that reads is self-consistent (one
// value per sample in every selected column, one line number per sample, increasing, after the
// header and within the file; with a run column, runs of distinct non-empty ids that tile the
// samples in order, and SplitRuns gives back every sample and line); the same bytes with every
// line end written as CRLF, and with a
// UTF-8 byte order mark in front, read the same (the same samples bit for bit and lines, or the
// same error at the same line); every error names the file. The same bytes as a MATLAB file go
// through the v5 checks and matio (any result, no crash). Build and run: tests/fuzz/run.sh.
//
// Input: byte 0 chooses the selected columns (bit 0: a normal force column, bit 1: a time
// column, bit 2: a run column "r"); the rest is the file.
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <string>
#include <string_view>

#include "rig_csv.h"

namespace {

void Fail(const char* what, const std::string& detail) {
  std::fprintf(stderr, "invariant: %s: %s\n", what, detail.c_str());
  std::abort();
}

// A scratch directory of this process, removed at exit (a plain array: the exit handler runs
// after static strings are destroyed).
char scratch_directory[] = "/tmp/mdr_rig_fuzz_XXXXXX";
constexpr const char* kScratchFiles[] = {"/in.csv", "/crlf.csv", "/bom.csv", "/in.mat"};

const char* ScratchDirectory() {
  static const bool made = [] {
    if (::mkdtemp(scratch_directory) == nullptr) Fail("mkdtemp", std::strerror(errno));
    std::atexit([] {
      for (const char* name : kScratchFiles) {
        std::remove((std::string(scratch_directory) + name).c_str());
      }
      ::rmdir(scratch_directory);
    });
    return true;
  }();
  return made ? scratch_directory : nullptr;
}

std::string Write(const char* name, std::string_view bytes) {
  const std::string path = std::string(ScratchDirectory()) + name;
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  return path;
}

// The file with every "\n" not already after a '\r' written as "\r\n".
std::string WithCrlf(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\n' && (i == 0 || text[i - 1] != '\r')) out += '\r';
    out += text[i];
  }
  return out;
}

bool SameBits(const google::protobuf::RepeatedField<double>& a,
              const google::protobuf::RepeatedField<double>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), sizeof(double) * a.size()) == 0);
}

// The same outcome, the file's path aside.
void ExpectSame(const mdr::Result<mdrctl::RigData>& a, const std::string& path_a,
                const mdr::Result<mdrctl::RigData>& b, const std::string& path_b,
                const char* variant) {
  if (a.ok() != b.ok()) Fail(variant, a.ok() ? b.status().ToString() : a.status().ToString());
  if (!a.ok()) {
    const std::string field_a = a.status().field(), field_b = b.status().field();
    if (field_a.substr(path_a.size()) != field_b.substr(path_b.size()) ||
        a.status().message() != b.status().message()) {
      Fail(variant, a.status().ToString() + " | " + b.status().ToString());
    }
    return;
  }
  if (a->lines != b->lines || !SameBits(a->samples.displacement(), b->samples.displacement()) ||
      !SameBits(a->samples.tangential_force(), b->samples.tangential_force()) ||
      !SameBits(a->samples.normal_force(), b->samples.normal_force()) ||
      !SameBits(a->samples.time(), b->samples.time()) || a->synthetic != b->synthetic ||
      a->runs.size() != b->runs.size()) {
    Fail(variant, "other samples, lines or marker");
  }
}

// The runs tile the samples in order, each id distinct and non-empty, and SplitRuns returns every
// sample and line once.
void CheckRuns(const mdrctl::RigData& data) {
  std::set<std::string> ids;
  std::size_t next = 0;
  for (const mdrctl::RigRun& run : data.runs) {
    if (run.id.empty() || !ids.insert(run.id).second || run.first != next || run.count == 0) {
      Fail("runs", "run " + mdrctl::Printable(run.id) + " at sample " + std::to_string(run.first));
    }
    next += run.count;
  }
  if (next != data.lines.size()) Fail("runs", "the runs do not cover every sample");
  std::vector<std::size_t> lines;
  int samples = 0;
  for (const mdrctl::RigData& piece : mdrctl::SplitRuns(data)) {
    lines.insert(lines.end(), piece.lines.begin(), piece.lines.end());
    samples += piece.samples.displacement_size();
  }
  if (lines != data.lines || samples != data.samples.displacement_size()) {
    Fail("runs", "SplitRuns lost or added samples");
  }
}

void CheckConsistent(const mdrctl::RigData& data, std::string_view text, bool normal, bool time) {
  const std::size_t n = data.lines.size();
  const auto size = [](const auto& column) { return static_cast<std::size_t>(column.size()); };
  if (n == 0 || size(data.samples.displacement()) != n ||
      size(data.samples.tangential_force()) != n ||
      size(data.samples.normal_force()) != (normal ? n : 0) ||
      size(data.samples.time()) != (time ? n : 0)) {
    Fail("consistent", "a column without one value per sample");
  }
  const std::size_t last_line =
      static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1;
  for (std::size_t i = 0; i < n; ++i) {
    if (data.lines[i] < 2 || data.lines[i] > last_line ||
        (i > 0 && data.lines[i] <= data.lines[i - 1])) {
      Fail("consistent",
           "line " + std::to_string(data.lines[i]) + " of sample " + std::to_string(i));
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool normal = (data[0] & 1) != 0, time = (data[0] & 2) != 0, runs = (data[0] & 4) != 0;
  const std::string_view text(reinterpret_cast<const char*>(data) + 1, size - 1);
  mdrctl::CsvLayout layout;
  layout.displacement_column = "x";
  layout.force_column = "f";
  if (normal) layout.normal_force_column = "n";
  if (time) layout.time_column = "t";
  if (runs) layout.run_column = "r";
  mdrctl::RigFileLimits limits;
  limits.max_line_bytes = 48;
  limits.max_samples = 16;

  const std::string path = Write("/in.csv", text);
  const auto read = mdrctl::ReadRigFile(path, layout, limits);
  if (read.ok()) {
    CheckConsistent(*read, text, normal, time);
    if (runs) CheckRuns(*read);
  } else if (!read.status().field().starts_with(path)) {
    Fail("the error names the file", read.status().ToString());
  }
  const std::string crlf = Write("/crlf.csv", WithCrlf(text));
  ExpectSame(read, path, mdrctl::ReadRigFile(crlf, layout, limits), crlf, "CRLF");
  if (!text.starts_with("\xEF\xBB\xBF")) {
    const std::string bom = Write("/bom.csv", "\xEF\xBB\xBF" + std::string(text));
    ExpectSame(read, path, mdrctl::ReadRigFile(bom, layout, limits), bom, "byte order mark");
  }

  const std::string mat = Write("/in.mat", text);
  const auto mat_read = mdrctl::ReadRigFile(mat, layout, limits);
  if (!mat_read.ok() && !mat_read.status().field().starts_with(mat)) {
    Fail("the MAT error names the file", mat_read.status().ToString());
  }
  return 0;
}
