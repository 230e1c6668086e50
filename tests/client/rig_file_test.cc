// A rig's samples from MATLAB files (ReadRigFile, rig_mat.cc): the same numbers as the CSV
// reader from the same samples, bit for bit, in every MAT version matio writes; struct fields and
// integer classes; and every refused variable named, with nothing read. The CSV reader's own
// bounds (lines read one at a time, samples and line length capped); its other errors are checked
// end to end through mdrctl (rig_analysis_test.py).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <matio.h>
#include <zlib.h>

#include <bit>
#include <cmath>
#include <complex>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "campaign.h"
#include "rig_csv.h"

namespace mdrctl {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// The samples of the checks below: awkward doubles (no short decimal form) and a negative zero.
const std::vector<double> kDisplacement{1.0 / 3, -2.5e-7, 0.1 + 0.2, -0.0, 7e-310, 12.75};
const std::vector<double> kForce{3.0, -1.0 / 7, 1e3, 2.2250738585072014e-308, -4.5, 0.0};
const std::vector<double> kTime{0, 0.001, 0.002, 0.003, 0.004, 0.005};

class MatWriter {
 public:
  MatWriter(const fs::path& path, mat_ft version)
      : mat_(Mat_CreateVer(path.c_str(), nullptr, version)) {}
  ~MatWriter() {
    if (mat_ != nullptr) Mat_Close(mat_);
  }
  bool ok() const { return mat_ != nullptr; }

  // A variable of `rows` x `cols` (matio copies the data).
  template <typename T>
  void Add(const char* name, matio_classes type, matio_types storage, std::vector<T> values,
           std::size_t rows, std::size_t cols, int flags = 0,
           matio_compression compression = MAT_COMPRESSION_NONE) {
    std::size_t dims[2] = {rows, cols};
    // For a complex variable, values holds one mat_complex_split_t: its address is the data.
    matvar_t* var = Mat_VarCreate(name, type, storage, 2, dims, values.data(), flags);
    ASSERT_NE(var, nullptr) << name;
    ASSERT_EQ(Mat_VarWrite(mat_, var, compression), 0) << name;
    Mat_VarFree(var);
  }
  void AddDoubles(const char* name, const std::vector<double>& values, bool row = false,
                  matio_compression compression = MAT_COMPRESSION_NONE) {
    Add(name, MAT_C_DOUBLE, MAT_T_DOUBLE, values, row ? 1 : values.size(), row ? values.size() : 1,
        0, compression);
  }
  // A 1x1 struct whose fields are column vectors of doubles.
  void AddStruct(const char* name,
                 const std::vector<std::pair<const char*, std::vector<double>>>& fields) {
    std::vector<const char*> names;
    for (const auto& field : fields) names.push_back(field.first);
    names.push_back(nullptr);
    std::size_t one[2] = {1, 1};
    matvar_t* structure = Mat_VarCreateStruct2(name, 2, one, names.data());
    ASSERT_NE(structure, nullptr);
    for (const auto& [field, values] : fields) {
      std::size_t dims[2] = {values.size(), 1};
      std::vector<double> copy = values;
      matvar_t* var = Mat_VarCreate(field, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, copy.data(), 0);
      Mat_VarSetStructFieldByName(structure, field, 0, var);
    }
    ASSERT_EQ(Mat_VarWrite(mat_, structure, MAT_COMPRESSION_NONE), 0);
    Mat_VarFree(structure);
  }

 private:
  mat_t* mat_;
};

// Bytes of numbers in either byte order (matio writes the machine's only).
class Bytes {
 public:
  explicit Bytes(bool big_endian) : big_endian_(big_endian) {}
  template <typename T>
  void Put(T value) {
    const char* p = reinterpret_cast<const char*>(&value);
    const bool reverse = big_endian_ == (std::endian::native == std::endian::little);
    for (std::size_t i = 0; i < sizeof value; ++i) text += p[reverse ? sizeof value - 1 - i : i];
  }
  void U32(std::uint32_t value) { Put(value); }
  std::string text;

 private:
  bool big_endian_;
};

// A MAT v5 file written byte by byte in either byte order: one column vector of doubles per
// variable, uncompressed.
std::string Mat5Bytes(bool big_endian,
                      const std::vector<std::pair<std::string, std::vector<double>>>& variables) {
  Bytes bytes(big_endian);
  bytes.text = "MATLAB 5.0 MAT-file, written by mdr's tests";
  bytes.text.resize(124, ' ');
  bytes.Put(std::uint16_t{0x0100});  // version
  bytes.Put(std::uint16_t{'M' << 8 | 'I'});
  for (const auto& [name, values] : variables) {
    const std::size_t padded_name = (name.size() + 7) / 8 * 8;
    bytes.U32(14);  // miMATRIX
    bytes.U32(static_cast<std::uint32_t>(16 + 16 + 8 + padded_name + 8 + 8 * values.size()));
    bytes.U32(6), bytes.U32(8), bytes.U32(6), bytes.U32(0);  // array flags: mxDOUBLE_CLASS
    bytes.U32(5), bytes.U32(8);                              // dims n x 1
    bytes.U32(static_cast<std::uint32_t>(values.size())), bytes.U32(1);
    bytes.U32(1), bytes.U32(static_cast<std::uint32_t>(name.size()));  // miINT8 name
    bytes.text += name;
    bytes.text.resize((bytes.text.size() + 7) / 8 * 8, '\0');
    bytes.U32(9), bytes.U32(static_cast<std::uint32_t>(8 * values.size()));  // miDOUBLE
    for (double value : values) bytes.Put(value);
  }
  return bytes.text;
}

CsvLayout Layout() {
  CsvLayout layout;
  layout.displacement_column = "x";
  layout.force_column = "fx";
  layout.normal_force_column = "fn";
  layout.time_column = "t";
  layout.displacement_unit = 1e-6;  // um
  layout.force_unit = 1e3;          // kN
  layout.time_unit = 1e-3;          // ms
  return layout;
}

// A MAT v4 file written byte by byte in either byte order: one column vector of doubles per
// variable (a header of type, rows, columns, imaginary flag and name length; the name; the data).
std::string Mat4Bytes(bool big_endian,
                      const std::vector<std::pair<std::string, std::vector<double>>>& variables) {
  Bytes bytes(big_endian);
  for (const auto& [name, values] : variables) {
    bytes.U32(big_endian ? 1000 : 0);  // MOPT: byte order, double precision, full numeric
    bytes.U32(static_cast<std::uint32_t>(values.size())), bytes.U32(1), bytes.U32(0);
    bytes.U32(static_cast<std::uint32_t>(name.size() + 1));
    bytes.text += name;
    bytes.text += '\0';
    for (double value : values) bytes.Put(value);
  }
  return bytes.text;
}

class RigFileTest : public ::testing::Test {
 protected:
  fs::path Path(const std::string& name) const { return dir_ / name; }
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mdr_rig_file_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The samples as a CSV file, every value with 17 significant digits.
  fs::path WriteCsv() const {
    const fs::path path = Path("samples.csv");
    std::ofstream out(path);
    out << "t,x,fx,fn\n";
    out.precision(17);
    for (std::size_t i = 0; i < kDisplacement.size(); ++i) {
      out << kTime[i] << ',' << kDisplacement[i] << ',' << kForce[i] << ',' << 0.1 * (i + 1)
          << '\n';
    }
    return path;
  }
  std::vector<double> NormalForce() const {
    std::vector<double> values;
    for (std::size_t i = 0; i < kDisplacement.size(); ++i) values.push_back(0.1 * (i + 1));
    return values;
  }
  void WriteColumns(MatWriter& mat, matio_compression compression = MAT_COMPRESSION_NONE) const {
    mat.AddDoubles("t", kTime, false, compression);
    mat.AddDoubles("x", kDisplacement, true, compression);  // a row vector
    mat.AddDoubles("fx", kForce, false, compression);
    mat.AddDoubles("fn", NormalForce(), false, compression);
  }
  // A v5 file of one complex variable "x" of 6 elements (1 + 2i).
  void WriteComplex(const char* name) const {
    MatWriter mat(Path(name), MAT_FT_MAT5);
    ASSERT_TRUE(mat.ok());
    std::vector<double> re(6, 1.0), im(6, 2.0);
    mat_complex_split_t split{re.data(), im.data()};
    mat.Add("x", MAT_C_DOUBLE, MAT_T_DOUBLE, std::vector<mat_complex_split_t>{split}, 6, 1,
            MAT_F_COMPLEX);
  }
  mdr::Status ReadError(const std::string& name, const CsvLayout& layout = Layout()) const {
    auto read = ReadRigFile(Path(name).string(), layout);
    EXPECT_FALSE(read.ok());
    return read.ok() ? mdr::OkStatus() : read.status();
  }

  fs::path dir_;
};

void ExpectSameBits(const google::protobuf::RepeatedField<double>& actual,
                    const google::protobuf::RepeatedField<double>& expected, const char* what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  for (int i = 0; i < actual.size(); ++i) {
    EXPECT_EQ(std::signbit(actual[i]), std::signbit(expected[i])) << what << "[" << i << "]";
    EXPECT_EQ(actual[i], expected[i]) << what << "[" << i << "]";
  }
}

TEST_F(RigFileTest, EveryMatVersionGivesTheCsvReadersNumbersBitForBit) {
  auto csv = ReadRigFile(WriteCsv().string(), Layout());
  ASSERT_TRUE(csv.ok()) << csv.status().ToString();
  ASSERT_EQ(csv->format, RigFormat::kCsv);
  struct Version {
    const char* file;
    mat_ft version;
    matio_compression compression;
  };
  for (const Version& v : {Version{"v5.mat", MAT_FT_MAT5, MAT_COMPRESSION_NONE},
                           Version{"v5_zlib.MAT", MAT_FT_MAT5, MAT_COMPRESSION_ZLIB},
                           Version{"v73.mat", MAT_FT_MAT73, MAT_COMPRESSION_NONE},
                           Version{"v4.mat", MAT_FT_MAT4, MAT_COMPRESSION_NONE}}) {
    SCOPED_TRACE(v.file);
    {
      MatWriter mat(Path(v.file), v.version);
      ASSERT_TRUE(mat.ok());
      WriteColumns(mat, v.compression);
    }
    auto read = ReadRigFile(Path(v.file).string(), Layout());
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    EXPECT_EQ(read->format, RigFormat::kMat);
    ExpectSameBits(read->samples.displacement(), csv->samples.displacement(), "displacement");
    ExpectSameBits(read->samples.tangential_force(), csv->samples.tangential_force(), "force");
    ExpectSameBits(read->samples.normal_force(), csv->samples.normal_force(), "normal force");
    ExpectSameBits(read->samples.time(), csv->samples.time(), "time");
    EXPECT_EQ(read->lines, (std::vector<std::size_t>{1, 2, 3, 4, 5, 6}));
  }
}

TEST_F(RigFileTest, StructFieldsAndIntegerClassesAreRead) {
  {
    MatWriter mat(Path("run.mat"), MAT_FT_MAT5);
    ASSERT_TRUE(mat.ok());
    mat.AddStruct("run", {{"x", kDisplacement}, {"fx", kForce}});
    mat.Add("counts", MAT_C_INT16, MAT_T_INT16, std::vector<std::int16_t>{-3, 0, 7, 32767, 1, 2}, 6,
            1);
    mat.Add("single", MAT_C_SINGLE, MAT_T_SINGLE, std::vector<float>{0.1f, 2, 3, 4, 5, 6}, 6, 1);
  }
  CsvLayout layout;
  layout.displacement_column = "run.x";
  layout.force_column = "run.fx";
  layout.normal_force_column = "counts";
  layout.time_column = "single";
  auto read = ReadRigFile(Path("run.mat").string(), layout);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->samples.displacement_size(), 6);
  for (int i = 0; i < 6; ++i) {
    EXPECT_EQ(read->samples.displacement(i), kDisplacement[i]);
    EXPECT_EQ(read->samples.tangential_force(i), kForce[i]);
  }
  EXPECT_EQ(read->samples.normal_force(0), -3);
  EXPECT_EQ(read->samples.normal_force(3), 32767);
  EXPECT_EQ(read->samples.time(0), static_cast<double>(0.1f));  // the stored float, exactly
}

TEST_F(RigFileTest, RefusedVariablesAreNamedWithTheirReason) {
  {
    MatWriter mat(Path("bad.mat"), MAT_FT_MAT5);
    ASSERT_TRUE(mat.ok());
    mat.AddDoubles("x", kDisplacement);
    mat.AddDoubles("short", {1, 2, 3});
    mat.Add("matrix", MAT_C_DOUBLE, MAT_T_DOUBLE, std::vector<double>(6, 1.0), 2, 3);
    mat.AddDoubles("with_nan", {1, 2, NAN, 4, 5, 6});
    mat.AddDoubles("with_inf", {1, 2, 3, 4, 5, -INFINITY});
    mat.Add("flags", MAT_C_UINT8, MAT_T_UINT8, std::vector<std::uint8_t>(6, 1), 6, 1,
            MAT_F_LOGICAL);
    mat.Add("label", MAT_C_CHAR, MAT_T_UINT8, std::vector<char>{'a', 'b', 'c'}, 1, 3);
    mat.AddDoubles("empty", {});
    mat.AddStruct("run", {{"x", kDisplacement}});
  }
  WriteComplex("complex.mat");
  const auto refused = [&](const std::string& force_column, const std::string& expected,
                           const char* file = "bad.mat") {
    SCOPED_TRACE(force_column);
    CsvLayout layout;
    layout.displacement_column = "x";
    layout.force_column = force_column;
    const mdr::Status status = ReadError(file, layout);
    EXPECT_EQ(status.code(), mdr::StatusCode::kInvalidArgument);
    EXPECT_EQ(status.field(), Path(file).string());
    EXPECT_THAT(status.message(), HasSubstr(expected));
  };
  refused("fx", R"(no variable "fx" in the file; its variables are "x", "short", "matrix")");
  refused("short", R"(variable "short" has 3 elements, "x" has 6: each needs one per sample)");
  refused("matrix", R"(variable "matrix" is a 2x3 array, not a vector)");
  refused("with_nan", R"(variable "with_nan", element 3: nan is not a finite number)");
  refused("with_inf", R"(variable "with_inf", element 6: -inf is not a finite number)");
  refused("flags", R"(variable "flags" is logical, not numeric)");
  refused("label", R"(variable "label" is a char array, not a real numeric vector)");
  refused("empty", R"(variable "empty" is empty)");
  refused("run", R"(variable "run" is a struct, not a real numeric vector)");
  refused("run.fx", R"(struct "run" has no field "fx"; its fields are "x")");
  refused("x.y", R"("x.y" names a field of a struct, but variable "x" is a numeric array)");
  refused("bad\x01name", R"(no variable "bad\x01name")");
  refused("x", R"(variable "x" is complex, not real)", "complex.mat");
}

// A rig that stops while writing leaves a file cut short. matio reads a MAT v5 file whose last
// variable is incomplete without an error (its missing elements whatever its buffer held): the
// reader refuses every truncation, at every byte, in every version and in both byte orders.
TEST_F(RigFileTest, ATruncatedFileIsRefusedAtEveryByte) {
  struct Version {
    const char* file;
    mat_ft version;
    matio_compression compression;
  };
  std::vector<std::pair<std::string, std::string>> files;  // name, bytes
  for (const Version& v : {Version{"v5.mat", MAT_FT_MAT5, MAT_COMPRESSION_NONE},
                           Version{"v5z.mat", MAT_FT_MAT5, MAT_COMPRESSION_ZLIB},
                           Version{"v73.mat", MAT_FT_MAT73, MAT_COMPRESSION_NONE},
                           Version{"v4.mat", MAT_FT_MAT4, MAT_COMPRESSION_NONE}}) {
    {
      MatWriter mat(Path(v.file), v.version);
      ASSERT_TRUE(mat.ok()) << v.file;
      WriteColumns(mat, v.compression);
    }
    std::ifstream in(Path(v.file), std::ios::binary);
    files.emplace_back(v.file, std::string(std::istreambuf_iterator<char>(in), {}));
  }
  const std::vector<std::pair<std::string, std::vector<double>>> columns{
      {"x", kDisplacement}, {"fx", kForce}, {"fn", NormalForce()}, {"t", kTime}};
  files.emplace_back("big_endian.mat", Mat5Bytes(true, columns));
  files.emplace_back("little_endian.mat", Mat5Bytes(false, columns));
  files.emplace_back("v4_big_endian.mat", Mat4Bytes(true, columns));
  for (const auto& [file, bytes] : files) {
    SCOPED_TRACE(file);
    std::ofstream(Path(file), std::ios::binary) << bytes;  // the hand-written ones
    auto whole = ReadRigFile(Path(file).string(), Layout());
    ASSERT_TRUE(whole.ok()) << whole.status().ToString();
    EXPECT_EQ(whole->samples.tangential_force(1), kForce[1] * 1e3);
    for (std::size_t length = 0; length < bytes.size(); ++length) {
      std::ofstream(Path("cut.mat"), std::ios::binary | std::ios::trunc) << bytes.substr(0, length);
      auto cut = ReadRigFile(Path("cut.mat").string(), Layout());
      ASSERT_FALSE(cut.ok()) << "cut at byte " << length << " of " << bytes.size();
    }
  }
  // The message says where, for a v5 file cut inside the data of its last variable.
  const std::string& v5 = files[0].second;
  std::ofstream(Path("cut.mat"), std::ios::binary | std::ios::trunc) << v5.substr(0, v5.size() - 3);
  EXPECT_THAT(ReadError("cut.mat").message(),
              HasSubstr("the file is truncated: it ends at byte " + std::to_string(v5.size() - 3) +
                        ", inside its variable number 4, which declares"));
}

// matio allocates what a file's byte counts declare: a corrupt name length of 2.6 GB would be
// allocated and cleared before the variable is found wanting. Every part of a v5 array must end
// inside its array, which the file's size bounds. And matio reads as many numbers as the
// dimensions declare, past the data when it holds fewer: a numeric array's data must match them.
TEST_F(RigFileTest, ACorruptByteCountOrDimensionIsRefusedBeforeMatioReadsIt) {
  const std::vector<std::pair<std::string, std::vector<double>>> columns{{"x", kDisplacement},
                                                                         {"fx", kForce}};
  for (const bool big_endian : {false, true}) {
    SCOPED_TRACE(big_endian ? "big-endian" : "little-endian");
    std::string bytes = Mat5Bytes(big_endian, columns);
    // Variable 1's name tag: after the header, its own tag, the flags and the dimensions.
    constexpr std::size_t kNameTag = 128 + 8 + 16 + 16;
    constexpr std::uint32_t kHugeCount = 0x9a000010;
    for (int i = 0; i < 4; ++i) {
      bytes[kNameTag + 4 + i] = static_cast<char>(kHugeCount >> (big_endian ? 24 - 8 * i : 8 * i));
    }
    std::ofstream(Path("corrupt.mat"), std::ios::binary | std::ios::trunc) << bytes;
    const std::size_t array_end = 128 + 8 + 16 + 16 + 8 + 8 + 8 + 8 * kDisplacement.size();
    EXPECT_THAT(
        ReadError("corrupt.mat").message(),
        HasSubstr("the file is corrupt: its variable number 1 has a part at byte " +
                  std::to_string(kNameTag) + " that declares " +
                  std::to_string(8 + std::uint64_t{kHugeCount}) +
                  " bytes, past the end of its array at byte " + std::to_string(array_end)));
    // Variable 1's first dimension (6 rows): more rows than its data holds, then fewer.
    constexpr std::size_t kRows = 128 + 8 + 16 + 8;
    for (const std::uint32_t rows : {std::uint32_t{16318664}, std::uint32_t{3}}) {
      std::string rows_corrupt = Mat5Bytes(big_endian, columns);
      for (int i = 0; i < 4; ++i) {
        rows_corrupt[kRows + i] = static_cast<char>(rows >> (big_endian ? 24 - 8 * i : 8 * i));
      }
      std::ofstream(Path("corrupt.mat"), std::ios::binary | std::ios::trunc) << rows_corrupt;
      EXPECT_THAT(ReadError("corrupt.mat").message(),
                  HasSubstr("the file is corrupt: its variable number 1 has an array of " +
                            std::to_string(rows) + " elements of 8 bytes, but its data holds " +
                            std::to_string(8 * kDisplacement.size()) + " bytes"));
    }
  }
}

// Issue #48: matio reported a corrupt zlib stream as a file without the variable ("its variables
// are none"); the stream is inflated before matio reads it and refused as corrupt.
TEST_F(RigFileTest, ACorruptCompressedVariableIsRefusedAsCorrupt) {
  {
    MatWriter mat(Path("z.mat"), MAT_FT_MAT5);
    ASSERT_TRUE(mat.ok());
    WriteColumns(mat, MAT_COMPRESSION_ZLIB);
  }
  std::ifstream in(Path("z.mat"), std::ios::binary);
  std::string bytes(std::istreambuf_iterator<char>(in), {});
  ASSERT_TRUE(ReadRigFile(Path("z.mat").string(), Layout()).ok());
  // Inside the first variable's zlib stream: after the header, its tag and zlib's own header.
  for (std::size_t i = 128 + 8 + 4; i < 128 + 8 + 12; ++i) bytes[i] = static_cast<char>(0xff);
  std::ofstream(Path("corrupt.mat"), std::ios::binary | std::ios::trunc) << bytes;
  EXPECT_THAT(ReadError("corrupt.mat").message(),
              HasSubstr("its variable number 1 (from byte 128) is compressed and its data is "
                        "corrupt"));
}

// The same rows with LF or CRLF line ends, a byte order mark, and cells long enough that rows
// straddle the reader's 64 KiB blocks: the same samples and lines.
TEST_F(RigFileTest, CsvRowsAcrossBlocksAndLineEndsReadTheSame) {
  const std::string filler(100000, 'a');  // an unselected column
  const auto write = [&](const std::string& name, const std::string& end, bool bom, bool last_end) {
    std::ofstream out(Path(name), std::ios::binary);
    out << (bom ? "\xEF\xBB\xBF" : "") << "# a comment" << end << "t,x,note,fx,fn" << end << end;
    out.precision(17);
    for (std::size_t i = 0; i < kDisplacement.size(); ++i) {
      out << kTime[i] << ',' << kDisplacement[i] << ',' << filler << ',' << kForce[i] << ','
          << NormalForce()[i];
      if (i + 1 < kDisplacement.size() || last_end) out << end;
    }
  };
  write("lf.csv", "\n", false, true);
  write("crlf.csv", "\r\n", true, true);
  auto plain = ReadRigFile(WriteCsv().string(), Layout());
  ASSERT_TRUE(plain.ok()) << plain.status().ToString();
  for (const char* name : {"lf.csv", "crlf.csv"}) {
    SCOPED_TRACE(name);
    auto read = ReadRigFile(Path(name).string(), Layout());
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    ExpectSameBits(read->samples.displacement(), plain->samples.displacement(), "displacement");
    ExpectSameBits(read->samples.tangential_force(), plain->samples.tangential_force(), "force");
    ExpectSameBits(read->samples.time(), plain->samples.time(), "time");
    EXPECT_EQ(read->lines, (std::vector<std::size_t>{4, 5, 6, 7, 8, 9}));
  }
}

// A file that ends inside a line may be cut short, its last cell with it ("20.0" written as far
// as "2"): refused at that line, whatever the line holds, LF or CRLF, across a block or not.
TEST_F(RigFileTest, ALastLineWithoutLineEndIsRefused) {
  const std::string filler(70000, 'a');  // the last line starts in one block, ends in the next
  for (const std::string& last : {std::string("1,1,2,2"), std::string("1,1,2,2\r"),
                                  std::string("# a comment"), "1," + filler + ",2,2"}) {
    SCOPED_TRACE(last.substr(0, 16));
    const bool wide = last.size() > 1000;
    std::ofstream(Path("cut.csv"), std::ios::binary | std::ios::trunc)
        << (wide ? "t,note,fx,fn\n0,a,2,20.0\n" : "t,x,fx,fn\n0,1,2,20.0\n") << last;
    CsvLayout layout = Layout();
    if (wide) layout.displacement_column = "fx";
    const mdr::Status status = ReadError("cut.csv", layout);
    EXPECT_EQ(status.field(), Path("cut.csv").string() + ":3");
    EXPECT_EQ(status.message(),
              "the last line has no line end: the file may be cut short (a rig still writing "
              "it?), its last cell cut with it; if the file is complete, end its last line with "
              "a line end");
  }
  std::ofstream(Path("whole.csv"), std::ios::binary) << "t,x,fx,fn\n0,1,2,20.0\n1,1,2,2\n";
  auto whole = ReadRigFile(Path("whole.csv").string(), Layout());
  ASSERT_TRUE(whole.ok()) << whole.status().ToString();
  EXPECT_EQ(whole->samples.normal_force(1), 2e3);
}

TEST_F(RigFileTest, CsvPastItsBoundsIsRefusedAtTheLineThatCrossesThem) {
  // By default the most samples one AnalyzeLoops call takes.
  EXPECT_EQ(RigFileLimits{}.max_samples, std::size_t{10'000'000});
  {
    std::ofstream out(Path("rows.csv"));
    out << "t,x,fx,fn\n0,1,2,3\n# a comment\n1,1,2,3\n2,1,2,3\n\n3,1,2,3\n";
  }
  RigFileLimits limits;
  limits.max_samples = 4;
  EXPECT_TRUE(ReadRigFile(Path("rows.csv").string(), Layout(), limits).ok());
  limits.max_samples = 3;
  auto rows = ReadRigFile(Path("rows.csv").string(), Layout(), limits);
  ASSERT_FALSE(rows.ok());
  EXPECT_EQ(rows.status().field(), Path("rows.csv").string() + ":7");
  EXPECT_EQ(rows.status().message(),
            "the file has more than 3 data rows (samples), the most mdrctl reads");

  // A line of exactly the bound is read (with CRLF too); one byte more is refused.
  limits = RigFileLimits{};
  limits.max_line_bytes = 12;
  {
    std::ofstream out(Path("lines.csv"), std::ios::binary);
    out << "t,x,fx,fn\r\n0,1,2,3.0000\r\n1,1,2,3.00000\r\n";  // 12 and 13 bytes
  }
  auto lines = ReadRigFile(Path("lines.csv").string(), Layout(), limits);
  ASSERT_FALSE(lines.ok());
  EXPECT_EQ(lines.status().field(), Path("lines.csv").string() + ":3");
  EXPECT_EQ(lines.status().message(),
            "the line is longer than 12 bytes, the most mdrctl reads in one line");
  limits.max_line_bytes = 13;
  EXPECT_TRUE(ReadRigFile(Path("lines.csv").string(), Layout(), limits).ok());

  // A file with no line end at all is refused after the bound, not read to its end.
  auto zeros = ReadRigFile("/dev/zero", Layout());
  ASSERT_FALSE(zeros.ok());
  EXPECT_EQ(zeros.status().field(), "/dev/zero:1");
  EXPECT_THAT(zeros.status().message(), HasSubstr("longer than 1048576 bytes"));

  const mdr::Status directory = ReadError("");
  EXPECT_THAT(directory.message(), HasSubstr("is a directory, not a CSV file"));

  // The samples' bound holds for a MAT file's variables too.
  {
    MatWriter mat(Path("six.mat"), MAT_FT_MAT5);
    ASSERT_TRUE(mat.ok());
    WriteColumns(mat);
  }
  limits.max_samples = 5;
  auto mat = ReadRigFile(Path("six.mat").string(), Layout(), limits);
  ASSERT_FALSE(mat.ok());
  EXPECT_THAT(mat.status().message(), HasSubstr("has 6 elements, more than the 5 mdrctl reads"));
}

// Tags where matio reads the flags and dimensions whatever they say: a small element of more
// than 4 bytes, flags of another type (a fuzzed file made matio allocate 2 GB this way), and a
// complex array whose imaginary part holds fewer elements than its dimensions declare.
TEST_F(RigFileTest, MisplacedArrayPartsAreRefusedBeforeMatioReadsThem) {
  const std::vector<std::pair<std::string, std::vector<double>>> columns{{"x", kDisplacement},
                                                                         {"fx", kForce}};
  for (const bool big_endian : {false, true}) {
    SCOPED_TRACE(big_endian ? "big-endian" : "little-endian");
    const auto corrupt = [&](std::size_t at, std::uint32_t value) {
      std::string bytes = Mat5Bytes(big_endian, columns);
      for (int i = 0; i < 4; ++i) {
        bytes[at + i] = static_cast<char>(value >> (big_endian ? 24 - 8 * i : 8 * i));
      }
      std::ofstream(Path("corrupt.mat"), std::ios::binary | std::ios::trunc) << bytes;
      return ReadError("corrupt.mat").message();
    };
    constexpr std::size_t kFlagsTag = 128 + 8;  // variable 1's first part
    EXPECT_EQ(corrupt(kFlagsTag, 8u << 16 | 6),
              "the file is corrupt: its variable number 1 has a part at byte 136 that declares 8 "
              "bytes in the 4 of a small element");
    EXPECT_EQ(
        corrupt(kFlagsTag, 9),
        R"(the file is corrupt: its variable number 1 has array flags at byte 136 of type 9 and 8 bytes, not 8 bytes of miUINT32)");
    EXPECT_THAT(corrupt(kFlagsTag + 16, 6),  // the dimensions' type
                HasSubstr("has dimensions at byte 152 of type 6 and 8 bytes, not a multiple of 4 "
                          "bytes of miINT32, at least 8"));
  }
  WriteComplex("complex.mat");
  std::ifstream in(Path("complex.mat"), std::ios::binary);
  std::string bytes(std::istreambuf_iterator<char>(in), {});
  // The imaginary part's tag, the second miDOUBLE tag of 48 bytes, says 40, and the variable
  // ends 8 bytes earlier (its count at byte 132, 0x98 bytes): every part still ends in place.
  const std::string tag("\x09\0\0\0\x30\0\0\0", 8);
  const std::size_t imaginary = bytes.find(tag, bytes.find(tag) + 8);
  ASSERT_NE(imaginary, std::string::npos);
  ASSERT_EQ(bytes.size(), 128 + 8 + 0x98u);
  bytes[imaginary + 4] = 0x28;
  bytes[132] = static_cast<char>(0x90);
  bytes.resize(bytes.size() - 8);
  std::ofstream(Path("corrupt.mat"), std::ios::binary | std::ios::trunc) << bytes;
  EXPECT_THAT(ReadError("corrupt.mat").message(),
              HasSubstr("has an array of 6 elements of 8 bytes, but its data holds 40 bytes"));
}

// An array element (miMATRIX) in either byte order: flags of `array_class`, its dimensions, its
// name, then `rest` (its data or its arrays, written by the caller).
std::string ArrayElement(bool big_endian, std::uint32_t array_class,
                         const std::vector<std::uint32_t>& dims, const std::string& name,
                         const std::string& rest) {
  Bytes bytes(big_endian);
  bytes.U32(6), bytes.U32(8), bytes.U32(array_class), bytes.U32(0);
  bytes.U32(5), bytes.U32(static_cast<std::uint32_t>(4 * dims.size()));
  for (std::uint32_t dim : dims) bytes.U32(dim);
  if (dims.size() % 2 != 0) bytes.U32(0);
  bytes.U32(1), bytes.U32(static_cast<std::uint32_t>(name.size()));
  bytes.text += name;
  bytes.text.resize((bytes.text.size() + 7) / 8 * 8, '\0');
  bytes.text += rest;
  Bytes element(big_endian);
  element.U32(14), element.U32(static_cast<std::uint32_t>(bytes.text.size()));
  return element.text + bytes.text;
}

// A 1x1 double, unnamed (a cell's element or a struct's field).
std::string OneDouble(bool big_endian, double value) {
  Bytes data(big_endian);
  data.U32(9), data.U32(8);
  data.Put(value);
  return ArrayElement(big_endian, 6, {1, 1}, "", data.text);
}

// A struct's field name length (a small element) and names, one field "v".
std::string OneFieldName(bool big_endian) {
  Bytes bytes(big_endian);
  bytes.U32(5 | 4u << 16), bytes.U32(8);
  bytes.U32(1), bytes.U32(8);
  bytes.text += std::string("v\0\0\0\0\0\0\0", 8);
  return bytes.text;
}

// `element` as a compressed variable (miCOMPRESSED: a zlib stream of it, not padded).
std::string Compressed(bool big_endian, const std::string& element) {
  uLongf size = compressBound(static_cast<uLong>(element.size()));
  std::string stream(size, '\0');
  EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(stream.data()), &size,
                      reinterpret_cast<const Bytef*>(element.data()),
                      static_cast<uLong>(element.size()), 6),
            Z_OK);
  stream.resize(size);
  Bytes bytes(big_endian);
  bytes.U32(15), bytes.U32(static_cast<std::uint32_t>(size));
  return bytes.text + stream;
}

// The rig fuzzer's find: matio allocates a pointer for every element a cell, a struct (times its
// fields) or a function handle declares before it reads them, 6 GB for a 480-byte file whose
// function handle declared 50331648 x 16 elements. Each must hold an array per element it
// declares, compressed or not, whatever its byte order; such variables that do are read past, and
// so is a variable after a compressed one, unaligned (its stream is not padded).
TEST_F(RigFileTest, ACellStructOrFunctionHandleMustHoldTheArraysItsDimensionsDeclare) {
  const std::vector<std::pair<std::string, std::vector<double>>> columns{{"x", kDisplacement},
                                                                         {"fx", kForce}};
  CsvLayout layout;
  layout.displacement_column = "x";
  layout.force_column = "fx";
  struct Case {
    const char* what;
    std::uint32_t array_class;
    std::vector<std::uint32_t> dims;
    bool with_field_names;
    const char* refusal;  // with the dimensions at the top of the container
  };
  const Case cases[] = {
      {"cell", 1, {50331648, 16}, false, "has a cell of 805306368 arrays, but holds 2"},
      {"struct",
       2,
       {4096, 4096},
       true,
       "has a struct of 16777216 elements x 1 fields, 16777216 arrays, but holds 2"},
      {"function handle",
       16,
       {50331648, 16},
       false,
       "has a function handle of 805306368 arrays, but holds 2"},
  };
  for (const bool big_endian : {false, true}) {
    for (const bool compressed : {false, true}) {
      for (const Case& c : cases) {
        SCOPED_TRACE(std::string(c.what) + (big_endian ? ", big-endian" : ", little-endian") +
                     (compressed ? ", compressed" : ""));
        const auto write = [&](const std::vector<std::uint32_t>& dims) {
          const std::string rest = (c.with_field_names ? OneFieldName(big_endian) : "") +
                                   OneDouble(big_endian, 1.5) + OneDouble(big_endian, -2);
          const std::string element = ArrayElement(big_endian, c.array_class, dims, "c", rest);
          std::ofstream(Path("c.mat"), std::ios::binary | std::ios::trunc)
              << Mat5Bytes(big_endian, columns)
              << (compressed ? Compressed(big_endian, element) : element);
        };
        write({2, 1});  // as many arrays as it declares
        auto read = ReadRigFile(Path("c.mat").string(), layout);
        ASSERT_TRUE(read.ok()) << read.status().ToString();
        EXPECT_EQ(read->samples.displacement_size(), static_cast<int>(kDisplacement.size()));
        write(c.dims);
        const std::string message = ReadError("c.mat", layout).message();
        EXPECT_THAT(message, HasSubstr(std::string("the file is corrupt: its variable number 3") +
                                       (compressed ? " (compressed) " : " ") + c.refusal));
      }
    }
  }
  // A cell nested in a struct's field, compressed: the walk reaches it in the inflated bytes.
  for (const bool big_endian : {false, true}) {
    const std::string cell = ArrayElement(big_endian, 1, {3, 1}, "",
                                          OneDouble(big_endian, 1) + OneDouble(big_endian, 2));
    const std::string element =
        ArrayElement(big_endian, 2, {1, 1}, "s", OneFieldName(big_endian) + cell);
    std::ofstream(Path("nested.mat"), std::ios::binary | std::ios::trunc)
        << Mat5Bytes(big_endian, columns) << Compressed(big_endian, element);
    EXPECT_THAT(
        ReadError("nested.mat", layout).message(),
        HasSubstr("its variable number 3 (compressed) has a cell of 3 arrays, but holds 2"));
    // A byte count past its array: the offsets named are the inflated data's.
    Bytes data(big_endian);
    data.U32(9), data.U32(800);
    data.Put(1.0);
    std::ofstream(Path("count.mat"), std::ios::binary | std::ios::trunc)
        << Mat5Bytes(big_endian, columns)
        << Compressed(big_endian, ArrayElement(big_endian, 6, {1, 1}, "d", data.text));
    EXPECT_THAT(ReadError("count.mat", layout).message(),
                HasSubstr("its variable number 3 (compressed) has a part at byte 56 that declares "
                          "808 bytes, past the end of its array at byte 72, counting bytes of its "
                          "inflated data"));
    // Variables after a compressed one, whose stream is not padded, start unaligned.
    Bytes three(big_endian);
    three.U32(9), three.U32(8);
    three.Put(3.0);
    const std::string first =
        Compressed(big_endian, ArrayElement(big_endian, 6, {1, 1}, "a", three.text));
    ASSERT_NE(first.size() % 8, 0u);
    std::ofstream(Path("unaligned.mat"), std::ios::binary | std::ios::trunc)
        << Mat5Bytes(big_endian, {}) << first << Mat5Bytes(big_endian, columns).substr(128);
    auto read = ReadRigFile(Path("unaligned.mat").string(), layout);
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    EXPECT_EQ(read->samples.tangential_force(1), kForce[1]);
  }
}

// matio allocates what a v4 header declares before it reads anything (opening a 123-byte file
// whose name length had a flipped byte took it 2 GB): every record is checked first.
TEST_F(RigFileTest, AVersion4FileIsCheckedBeforeMatioOpensIt) {
  auto csv = ReadRigFile(WriteCsv().string(), Layout());
  ASSERT_TRUE(csv.ok()) << csv.status().ToString();
  const std::vector<std::pair<std::string, std::vector<double>>> columns{
      {"x", kDisplacement}, {"fx", kForce}, {"fn", NormalForce()}, {"t", kTime}};
  for (const bool big_endian : {false, true}) {
    SCOPED_TRACE(big_endian ? "big-endian" : "little-endian");
    const std::string bytes = Mat4Bytes(big_endian, columns);
    std::ofstream(Path("v4.mat"), std::ios::binary | std::ios::trunc) << bytes;
    auto read = ReadRigFile(Path("v4.mat").string(), Layout());
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    ExpectSameBits(read->samples.displacement(), csv->samples.displacement(), "displacement");
    ExpectSameBits(read->samples.time(), csv->samples.time(), "time");

    // The message for the file with the given words written over it.
    const auto corrupt = [&](std::initializer_list<std::pair<std::size_t, std::uint32_t>> words) {
      std::string text = bytes;
      for (const auto& [at, value] : words) {
        for (int i = 0; i < 4; ++i) {
          text[at + i] = static_cast<char>(value >> (big_endian ? 24 - 8 * i : 8 * i));
        }
      }
      std::ofstream(Path("corrupt.mat"), std::ios::binary | std::ios::trunc) << text;
      return ReadError("corrupt.mat").message();
    };
    constexpr std::uint32_t kHuge = 0x78010000;
    EXPECT_EQ(corrupt({{16, kHuge}}),  // variable 1's name length
              "the file is truncated: it ends at byte " + std::to_string(bytes.size()) +
                  ", inside its variable number 1, which declares " +
                  std::to_string(20 + std::uint64_t{kHuge} + 8 * kDisplacement.size()) +
                  " bytes from byte 0; was it still being written?");
    const std::size_t second = 20 + 2 + 8 * kDisplacement.size();  // variable 2's header
    EXPECT_THAT(corrupt({{second + 4, kHuge}}),                    // its rows
                HasSubstr("inside its variable number 2, which declares " +
                          std::to_string(20 + 3 + 8 * std::uint64_t{kHuge}) + " bytes from byte " +
                          std::to_string(second)));
    // Rows, columns and an imaginary part past what 64 bits count (found by the rig fuzzer).
    EXPECT_THAT(corrupt({{4, 0x7fffffff}, {8, 0x7fffffff}, {12, 1}}),
                HasSubstr("inside its variable number 1, which declares more than 2^64 bytes"));
    EXPECT_EQ(corrupt({{second, big_endian ? 1009u : 9u}}),  // a type of no v4 kind
              "the file is corrupt: its variable number 2 at byte " + std::to_string(second) +
                  " has no MAT v4 header");
  }
}

TEST_F(RigFileTest, AFileThatIsNotMatlabIsRefused) {
  std::ofstream(Path("text.mat")) << "t,x,fx\n0,1,2\n";
  const mdr::Status status = ReadError("text.mat");
  EXPECT_EQ(status.field(), Path("text.mat").string());
  EXPECT_THAT(status.message(), HasSubstr("cannot open as a MATLAB file (version 4, 5 or 7.3)"));
  EXPECT_THAT(ReadError("missing.mat").message(), HasSubstr("cannot open as a MATLAB file"));
}

TEST_F(RigFileTest, ServiceErrorsAboutASampleNameTheVariableAndElement) {
  RigData data;
  data.path = "run.mat";
  data.format = RigFormat::kMat;
  data.lines = {1, 2, 3};
  const mdr::Status status =
      LocateSampleError("samples.tangential_force[2]", "must be finite", data, Layout());
  EXPECT_EQ(status.field(), "run.mat");
  EXPECT_EQ(status.message(), R"(variable "fx", element 3: must be finite)");
  data.format = RigFormat::kCsv;
  data.lines = {5, 6, 9};
  const mdr::Status csv =
      LocateSampleError("samples.tangential_force[2]", "must be finite", data, Layout());
  EXPECT_EQ(csv.field(), "run.mat:9");
  EXPECT_EQ(csv.message(), R"(column "fx": must be finite)");
}

// A torsional record reads its twist and twisting-moment columns into LoopSamples.twist and
// twisting_moment, in their own units (the force unit is the normal force's alone), from a CSV
// and a MAT file alike; a service error about them names their columns.
TEST_F(RigFileTest, TorsionalRecordsReadTheTwistAndTheMoment) {
  CsvLayout layout = Layout();
  layout.channel = mdr::analysis::LoopChannel::kTorsional;
  layout.twist_column = "x";
  layout.moment_column = "fx";
  layout.twist_unit = 1e-3;   // mrad
  layout.moment_unit = 1e-3;  // N mm
  auto csv = ReadRigFile(WriteCsv().string(), layout);
  ASSERT_TRUE(csv.ok()) << csv.status().ToString();
  EXPECT_TRUE(csv->samples.displacement().empty());
  EXPECT_TRUE(csv->samples.tangential_force().empty());
  ASSERT_EQ(csv->samples.twist_size(), static_cast<int>(kDisplacement.size()));
  for (std::size_t i = 0; i < kDisplacement.size(); ++i) {
    const int k = static_cast<int>(i);
    EXPECT_EQ(csv->samples.twist(k), kDisplacement[i] * 1e-3) << i;
    EXPECT_EQ(csv->samples.twisting_moment(k), kForce[i] * 1e-3) << i;
    EXPECT_EQ(csv->samples.normal_force(k), NormalForce()[i] * 1e3) << i;  // kN
  }
  {
    MatWriter mat(Path("twist.mat"), MAT_FT_MAT5);
    ASSERT_TRUE(mat.ok());
    WriteColumns(mat, MAT_COMPRESSION_NONE);
  }
  auto mat = ReadRigFile(Path("twist.mat").string(), layout);
  ASSERT_TRUE(mat.ok()) << mat.status().ToString();
  ExpectSameBits(mat->samples.twist(), csv->samples.twist(), "twist");
  ExpectSameBits(mat->samples.twisting_moment(), csv->samples.twisting_moment(), "moment");
  EXPECT_EQ(&LoopPositions(csv->samples), &csv->samples.twist());
  EXPECT_EQ(&LoopForces(csv->samples), &csv->samples.twisting_moment());
  const mdr::Status status =
      LocateSampleError("samples.twisting_moment[2]", "must be finite", *csv, layout);
  EXPECT_EQ(status.field(), csv->path + ":4");
  EXPECT_EQ(status.message(), R"(column "fx": must be finite)");
  EXPECT_EQ(
      LocateSampleError("sets[1].samples.twist", "spans only 1e-16 rad", *csv, layout).message(),
      R"(column "x": spans only 1e-16 rad)");
}

// A file of several runs (a run column): every run in the order it first appears, each a
// contiguous block of rows, its ids as the cells write them (trimmed, unquoted).
TEST_F(RigFileTest, CsvRunsAreSplitByTheRunColumn) {
  std::ofstream(Path("runs.csv"), std::ios::binary)
      << "# three runs\nrun,t,x,fx,fn\n\"a\",0,1,2,3\n a ,1,2,3,4\n\n b,2,3,4,5\n"
      << "# between\n10,3,4,5,6\n10,4,5,6,7\n10,5,6,7,8\n";
  CsvLayout layout = Layout();
  layout.run_column = "run";
  auto file = ReadRigFile(Path("runs.csv").string(), layout);
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  ASSERT_EQ(file->runs.size(), 3u);
  EXPECT_EQ(file->runs[0].id, "a");
  EXPECT_EQ(file->runs[1].id, "b");
  EXPECT_EQ(file->runs[2].id, "10");
  EXPECT_EQ(file->runs[2].first, 3u);
  EXPECT_EQ(file->runs[2].count, 3u);
  EXPECT_FALSE(file->run);

  const std::vector<RigData> runs = SplitRuns(*file);
  ASSERT_EQ(runs.size(), 3u);
  EXPECT_EQ(runs[0].run, "a");
  EXPECT_EQ(runs[0].lines, (std::vector<std::size_t>{3, 4}));
  EXPECT_EQ(runs[1].lines, (std::vector<std::size_t>{6}));
  EXPECT_EQ(runs[2].lines, (std::vector<std::size_t>{8, 9, 10}));
  EXPECT_EQ(runs[2].samples.displacement_size(), 3);
  EXPECT_DOUBLE_EQ(runs[2].samples.displacement(0), 4e-6);
  EXPECT_EQ(runs[2].samples.tangential_force(2), 7e3);
  EXPECT_EQ(runs[2].samples.normal_force(1), 7e3);
  EXPECT_DOUBLE_EQ(runs[2].samples.time(2), 5e-3);
  EXPECT_TRUE(runs[2].runs.empty());

  auto b = SelectRun(*file, layout, "b");
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  EXPECT_EQ(b->run, "b");
  EXPECT_EQ(b->samples.displacement_size(), 1);
  EXPECT_EQ(b->samples.tangential_force(0), 4e3);

  // A service error about a sample of a run lands on its line in the file.
  const mdr::Status located =
      LocateSampleError("samples.time[1]", "must increase strictly", runs[2], layout);
  EXPECT_EQ(located.field(), Path("runs.csv").string() + ":9");

  // Without the run column the file is one set.
  auto whole = ReadRigFile(Path("runs.csv").string(), Layout());
  ASSERT_TRUE(whole.ok());
  EXPECT_TRUE(whole->runs.empty());
  EXPECT_EQ(SplitRuns(*whole).size(), 1u);
  EXPECT_EQ(SplitRuns(*whole).front().lines.size(), 6u);
}

TEST_F(RigFileTest, AMissingRunIsNamedWithTheFilesRuns) {
  std::ofstream(Path("runs.csv"), std::ios::binary)
      << "run,t,x,fx,fn\np50,0,1,2,3\np50,1,1,2,3\n\"p\x1b" << std::string(80, 'x')
      << "\",2,1,2,3\n";
  CsvLayout layout = Layout();
  layout.run_column = "run";
  auto file = ReadRigFile(Path("runs.csv").string(), layout);
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  auto missing = SelectRun(*file, layout, "p\"200");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().field(), Path("runs.csv").string());
  EXPECT_EQ(missing.status().message(),
            R"(no run "p\"200" in column "run"; its runs are "p50", "p\x1B)" +
                std::string(62, 'x') + R"(...")");
}

TEST_F(RigFileTest, AnInterleavedRunIsRefusedAtItsLine) {
  std::ofstream(Path("interleaved.csv"), std::ios::binary)
      << "run,t,x,fx,fn\na,0,1,2,3\na,1,1,2,3\nb,2,1,2,3\n# c\na,3,1,2,3\n";
  CsvLayout layout = Layout();
  layout.run_column = "run";
  const mdr::Status status = ReadError("interleaved.csv", layout);
  EXPECT_EQ(status.field(), Path("interleaved.csv").string() + ":6");
  EXPECT_EQ(status.message(),
            R"(column "run": run "a" appears again after run "b" (its rows ended at line 3): )"
            "the rows of a run must be contiguous; interleaved runs are usually a bad export");
}

TEST_F(RigFileTest, AnEmptyRunCellOrAMissingRunColumnIsRefused) {
  CsvLayout layout = Layout();
  layout.run_column = "run";
  for (const char* cell : {"", "  ", "\"\""}) {
    SCOPED_TRACE(cell);
    std::ofstream(Path("empty.csv"), std::ios::binary | std::ios::trunc)
        << "t,x,fx,fn,run\n0,1,2,3,a\n1,1,2,3," << cell << "\n";
    const mdr::Status status = ReadError("empty.csv", layout);
    EXPECT_EQ(status.field(), Path("empty.csv").string() + ":3");
    EXPECT_EQ(status.message(), R"(column "run": the cell is empty: every row needs its run's id)");
  }
  std::ofstream(Path("none.csv"), std::ios::binary) << "t,x,fx,fn\n0,1,2,3\n";
  const mdr::Status none = ReadError("none.csv", layout);
  EXPECT_EQ(none.field(), Path("none.csv").string() + ":1");
  EXPECT_THAT(none.message(), HasSubstr(R"(no column "run" in the header)"));
}

// A MAT file's run variable is a numeric vector like the others: its elements are the ids,
// integers in decimal (1000000, not 1e+06), in every version matio writes.
TEST_F(RigFileTest, MatRunsAreSplitByTheRunVariable) {
  const std::vector<double> run{7, 7, 1000000, 1000000, 2.5, 2.5};
  CsvLayout layout = Layout();
  layout.run_column = "run";
  for (const mat_ft version : {MAT_FT_MAT5, MAT_FT_MAT73, MAT_FT_MAT4}) {
    SCOPED_TRACE(version);
    {
      MatWriter mat(Path("runs.mat"), version);
      ASSERT_TRUE(mat.ok());
      WriteColumns(mat);
      mat.AddDoubles("run", run);
    }
    auto file = ReadRigFile(Path("runs.mat").string(), layout);
    ASSERT_TRUE(file.ok()) << file.status().ToString();
    ASSERT_EQ(file->runs.size(), 3u);
    EXPECT_EQ(file->runs[0].id, "7");
    EXPECT_EQ(file->runs[1].id, "1000000");
    EXPECT_EQ(file->runs[2].id, "2.5");
    auto selected = SelectRun(*file, layout, "1000000");
    ASSERT_TRUE(selected.ok()) << selected.status().ToString();
    EXPECT_EQ(selected->lines, (std::vector<std::size_t>{3, 4}));
    EXPECT_EQ(selected->samples.displacement(0), kDisplacement[2] * 1e-6);
    auto missing = SelectRun(*file, layout, "8");
    ASSERT_FALSE(missing.ok());
    EXPECT_EQ(missing.status().message(),
              R"(no run "8" in variable "run"; its runs are "7", "1000000", "2.5")");
  }
  {
    MatWriter mat(Path("bad_runs.mat"), MAT_FT_MAT5);
    ASSERT_TRUE(mat.ok());
    WriteColumns(mat);
    mat.Add("interleaved", MAT_C_INT32, MAT_T_INT32, std::vector<std::int32_t>{1, 2, 2, 1, 1, 1}, 6,
            1);
    mat.AddDoubles("missing", {1, 1, NAN, 2, 2, 2});
    mat.AddDoubles("short", {1, 1, 2});
  }
  const auto refused = [&](const char* variable) {
    layout.run_column = variable;
    const mdr::Status status = ReadError("bad_runs.mat", layout);
    EXPECT_EQ(status.field(), Path("bad_runs.mat").string());
    return status.message();
  };
  EXPECT_EQ(refused("interleaved"),
            R"(variable "interleaved", element 4: run "1" appears again after run "2" (its rows )"
            "ended at element 1): the rows of a run must be contiguous; interleaved runs are "
            "usually a bad export");
  EXPECT_EQ(refused("missing"), R"(variable "missing", element 3: nan is not a finite number)");
  EXPECT_THAT(refused("short"), HasSubstr(R"(variable "short" has 3 elements, "x" has 6)"));
}

// A campaign file that is not YAML, or cannot be read, is the document's error: no field is
// named (a field is a campaign key), the message names the file and, for a syntax error, its line
// and column.
TEST(CampaignFileTest, ASyntaxErrorNamesTheFileNotAField) {
  const fs::path dir = fs::path(::testing::TempDir()) / "campaign_file_test";
  fs::create_directories(dir);
  const fs::path broken = dir / "broken.yaml";
  std::ofstream(broken) << "title: x\nfree: [{parameter: friction\n";
  const mdr::Result<Campaign> syntax = LoadCampaign(broken.string());
  ASSERT_FALSE(syntax.ok());
  EXPECT_EQ(syntax.status().field(), "");
  EXPECT_THAT(syntax.status().message(), HasSubstr(broken.string() + ": line "));
  EXPECT_THAT(syntax.status().message(), HasSubstr("column"));
  const mdr::Result<Campaign> missing = LoadCampaign((dir / "absent.yaml").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().field(), "");
  EXPECT_THAT(missing.status().message(), HasSubstr("absent.yaml: cannot open"));
  const fs::path list = dir / "list.yaml";
  std::ofstream(list) << "- 1\n- 2\n";
  const mdr::Result<Campaign> not_a_map = LoadCampaign(list.string());
  ASSERT_FALSE(not_a_map.ok());
  EXPECT_EQ(not_a_map.status().field(), "");
  EXPECT_THAT(not_a_map.status().message(), HasSubstr("list.yaml: must be a YAML mapping"));
}

}  // namespace
}  // namespace mdrctl
