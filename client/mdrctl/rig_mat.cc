// A test rig's MATLAB file (rig_csv.h): the selected variables through matio, checked before
// their data is read (class, shape, size), converted to SI.
#include <matio.h>
#include <zlib.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rig_csv.h"

namespace mdrctl {
namespace {

// matio reports through a log function; its default one aborts the process on errors. This one
// keeps the last message for the error mdrctl prints (matio is used from one thread here).
std::string& LastMatioMessage() {
  static std::string message;
  return message;
}

void KeepMatioMessage(int /*log_level*/, char* message) {
  LastMatioMessage() = message == nullptr ? "" : message;
}

std::string MatioDetail() {
  const std::string& message = LastMatioMessage();
  return message.empty() ? "" : " (matio: " + Printable(message, 160) + ")";
}

struct MatCloser {
  void operator()(mat_t* mat) const { Mat_Close(mat); }
};
struct VarFreer {
  void operator()(matvar_t* var) const { Mat_VarFree(var); }
};
using MatFile = std::unique_ptr<mat_t, MatCloser>;
using MatVar = std::unique_ptr<matvar_t, VarFreer>;

std::string NameOf(const matvar_t* var) { return var->name == nullptr ? "" : var->name; }

// The names of the file's variables (at most 32, then "..."), for an error.
std::string VariableNames(mat_t* mat) {
  std::string names;
  Mat_Rewind(mat);
  int count = 0;
  while (MatVar var{Mat_VarReadNextInfo(mat)}) {
    if (count++ == 32) {
      names += ", ...";
      break;
    }
    names += (names.empty() ? "" : ", ") + Printable(NameOf(var.get()));
  }
  return names.empty() ? "none" : names;
}

std::string FieldNames(matvar_t* structure) {
  const unsigned fields = Mat_VarGetNumberOfFields(structure);
  char* const* names = Mat_VarGetStructFieldnames(structure);
  std::string listed;
  for (unsigned i = 0; i < fields && i < 32; ++i) {
    listed += (i ? ", " : "") + Printable(names[i] == nullptr ? "" : names[i]);
  }
  if (fields > 32) listed += ", ...";
  return listed.empty() ? "none" : listed;
}

bool Numeric(matio_classes type) {
  switch (type) {
    case MAT_C_DOUBLE:
    case MAT_C_SINGLE:
    case MAT_C_INT8:
    case MAT_C_UINT8:
    case MAT_C_INT16:
    case MAT_C_UINT16:
    case MAT_C_INT32:
    case MAT_C_UINT32:
    case MAT_C_INT64:
    case MAT_C_UINT64:
      return true;
    default:
      return false;
  }
}

const char* ClassName(matio_classes type) {
  switch (type) {
    case MAT_C_CELL:
      return "a cell array";
    case MAT_C_STRUCT:
      return "a struct";
    case MAT_C_OBJECT:
      return "an object";
    case MAT_C_CHAR:
      return "a char array";
    case MAT_C_SPARSE:
      return "a sparse matrix";
    case MAT_C_FUNCTION:
      return "a function handle";
    default:
      return Numeric(type) ? "a numeric array" : "of a class mdrctl does not read";
  }
}

// Splits "run.force" into the variable and the field ("" when there is none).
std::pair<std::string, std::string> SplitName(const std::string& name) {
  const std::size_t dot = name.find('.');
  if (dot == std::string::npos) return {name, ""};
  return {name.substr(0, dot), name.substr(dot + 1)};
}

// The selected vector inside `top` (itself, or its field), or an error naming it.
mdr::Result<matvar_t*> Leaf(matvar_t* top, const std::string& name, const std::string& field,
                            const std::string& path) {
  if (field.empty()) return top;
  if (top->class_type != MAT_C_STRUCT || Mat_VarGetNumberOfFields(top) == 0) {
    return mdr::InvalidArgument(path,
                                Printable(name) + " names a field of a struct, but variable " +
                                    Printable(NameOf(top)) + " is " + ClassName(top->class_type));
  }
  std::size_t elements = 1;
  for (int d = 0; d < top->rank; ++d) elements *= top->dims[d];
  if (elements != 1) {
    return mdr::InvalidArgument(path, "variable " + Printable(NameOf(top)) +
                                          " is a struct array; " + Printable(name) +
                                          " needs a 1x1 struct");
  }
  matvar_t* leaf = Mat_VarGetStructFieldByName(top, field.c_str(), 0);
  if (leaf == nullptr) {
    return mdr::InvalidArgument(path, "struct " + Printable(NameOf(top)) + " has no field " +
                                          Printable(field) + "; its fields are " + FieldNames(top));
  }
  return leaf;
}

// The length of a real numeric vector of at most max_samples elements, or an error saying why the
// variable is not one.
mdr::Result<std::size_t> VectorLength(const matvar_t* var, const std::string& name,
                                      const std::string& path, std::size_t max_samples) {
  const std::string what = "variable " + Printable(name);
  if (var->isLogical) return mdr::InvalidArgument(path, what + " is logical, not numeric");
  if (!Numeric(var->class_type)) {
    return mdr::InvalidArgument(
        path, what + " is " + ClassName(var->class_type) + ", not a real numeric vector");
  }
  if (var->isComplex) return mdr::InvalidArgument(path, what + " is complex, not real");
  std::size_t length = 1, longest = 1;
  std::string shape;
  for (int d = 0; d < var->rank; ++d) {
    length *= var->dims[d];
    longest = std::max(longest, var->dims[d]);
    if (d > 0) shape += 'x';
    shape += std::to_string(var->dims[d]);
  }
  if (var->rank < 1 || length == 0) return mdr::InvalidArgument(path, what + " is empty");
  if (length != longest) {
    return mdr::InvalidArgument(
        path, what + " is a " + shape + " array, not a vector (one row or one column)");
  }
  if (length > max_samples) {
    return mdr::InvalidArgument(path, what + " has " + std::to_string(length) +
                                          " elements, more than the " +
                                          std::to_string(max_samples) + " mdrctl reads");
  }
  return length;
}

template <typename T>
void Append(const void* data, std::size_t length, std::vector<double>* values) {
  const T* typed = static_cast<const T*>(data);
  for (std::size_t i = 0; i < length; ++i) values->push_back(static_cast<double>(typed[i]));
}

// The vector's data as doubles (matio stores a numeric array in its class's type).
mdr::Result<std::vector<double>> Values(const matvar_t* var, std::size_t length,
                                        const std::string& name, const std::string& path) {
  std::vector<double> values;
  values.reserve(length);
  const std::size_t bytes = var->data_size * length;
  if (var->data == nullptr || var->data_size == 0 || var->nbytes < bytes) {
    return mdr::InvalidArgument(
        path, "variable " + Printable(name) + ": its data could not be read" + MatioDetail());
  }
  switch (var->data_type) {
    case MAT_T_DOUBLE:
      Append<double>(var->data, length, &values);
      break;
    case MAT_T_SINGLE:
      Append<float>(var->data, length, &values);
      break;
    case MAT_T_INT8:
      Append<std::int8_t>(var->data, length, &values);
      break;
    case MAT_T_UINT8:
      Append<std::uint8_t>(var->data, length, &values);
      break;
    case MAT_T_INT16:
      Append<std::int16_t>(var->data, length, &values);
      break;
    case MAT_T_UINT16:
      Append<std::uint16_t>(var->data, length, &values);
      break;
    case MAT_T_INT32:
      Append<std::int32_t>(var->data, length, &values);
      break;
    case MAT_T_UINT32:
      Append<std::uint32_t>(var->data, length, &values);
      break;
    case MAT_T_INT64:
      Append<std::int64_t>(var->data, length, &values);
      break;
    case MAT_T_UINT64:
      Append<std::uint64_t>(var->data, length, &values);
      break;
    default:
      return mdr::InvalidArgument(
          path, "variable " + Printable(name) + " is stored in a type mdrctl does not read");
  }
  return values;
}

// One selected column: checked from the variable's header (its length against `first`'s, when
// that was read before), then read and converted.
mdr::Status ReadColumn(mat_t* mat, const SelectedColumn& column, const SelectedColumn* first,
                       const std::string& path, std::size_t max_samples, std::size_t* length) {
  const auto [variable, field] = SplitName(column.name);
  LastMatioMessage().clear();
  MatVar info{Mat_VarReadInfo(mat, variable.c_str())};
  if (info == nullptr) {
    return mdr::InvalidArgument(path, "no variable " + Printable(variable) +
                                          " in the file; its variables are " + VariableNames(mat));
  }
  auto leaf = Leaf(info.get(), column.name, field, path);
  if (!leaf.ok()) return leaf.status();
  auto count = VectorLength(*leaf, column.name, path, max_samples);
  if (!count.ok()) return count.status();
  if (first != nullptr && *count != *length) {
    return mdr::InvalidArgument(path, "variable " + Printable(column.name) + " has " +
                                          std::to_string(*count) + " elements, " +
                                          Printable(first->name) + " has " +
                                          std::to_string(*length) + ": each needs one per sample");
  }
  *length = *count;
  MatVar read{Mat_VarRead(mat, variable.c_str())};
  if (read == nullptr) {
    return mdr::InvalidArgument(
        path, "variable " + Printable(variable) + " could not be read" + MatioDetail());
  }
  auto read_leaf = Leaf(read.get(), column.name, field, path);
  if (!read_leaf.ok()) return read_leaf.status();
  auto values = Values(*read_leaf, *count, column.name, path);
  if (!values.ok()) return values.status();
  for (std::size_t i = 0; i < values->size(); ++i) {
    if (!std::isfinite((*values)[i])) {
      return mdr::InvalidArgument(
          path, "variable " + Printable(column.name) + ", element " + std::to_string(i + 1) + ": " +
                    std::to_string((*values)[i]) + " is not a finite number");
    }
    column.values->Add((*values)[i] * column.factor);
  }
  return mdr::OkStatus();
}

// A file cut short inside its variable number `variable`, which starts at byte `at` and declares
// `bytes` ("" when its header is cut too).
mdr::Status Truncated(const std::string& path, std::streamoff size, int variable, std::streamoff at,
                      const std::string& bytes) {
  return mdr::InvalidArgument(
      path, "the file is truncated: it ends at byte " + std::to_string(size) +
                ", inside its variable number " + std::to_string(variable) + ", which " +
                (bytes.empty() ? "starts at byte " + std::to_string(at)
                               : "declares " + bytes + " bytes from byte " + std::to_string(at)) +
                "; was it still being written?");
}

// Whether the file starts with a MAT v5 (or 7.3) header: 128 bytes ending in "MI" either way
// round. Other files are read as version 4 or refused.
bool HasMat5Header(const std::string& path) {
  char header[128];
  std::ifstream in(path, std::ios::binary);
  if (!in.read(header, sizeof header)) return false;
  return (header[126] == 'M' && header[127] == 'I') || (header[126] == 'I' && header[127] == 'M');
}

// A MAT v4 file is one record per variable: a header of five 32-bit integers (its type as the
// digits MOPT: byte order M, 0 little-endian or 1 big-endian; O 0; precision P, 0-5; kind T,
// 0-2; then rows, columns, an imaginary flag and the name's length), the name, and rows x columns
// elements of the precision (twice that with an imaginary part). matio allocates what a header
// declares before it reads the file: a flipped byte in a name's length made it take 2 GB to open
// a file of 123 bytes. So before matio opens it, every record must hold what it declares.
// nullopt: the first record's header is not one of version 4 (the file is not a MATLAB file).
std::optional<mdr::Status> CheckMat4Records(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  const std::streamoff size = in.tellg();
  if (!in || size < 20 || !in.seekg(0)) return std::nullopt;
  std::streamoff at = 0;
  for (int variable = 1; at < size; ++variable) {
    if (size - at < 20) return Truncated(path, size, variable, at, "");
    std::uint32_t header[5];
    in.seekg(at);
    in.read(reinterpret_cast<char*>(header), sizeof header);
    if (!in) return Truncated(path, size, variable, at, "");
    // The type is under 5000 in its own byte order: little-endian if it reads so with M = 0.
    const bool swapped = !(header[0] < 1000);
    if (swapped) {
      for (std::uint32_t& word : header) word = __builtin_bswap32(word);
    }
    const std::uint32_t type = header[0], rows = header[1], columns = header[2];
    const std::uint32_t imaginary = header[3], name_bytes = header[4];
    constexpr std::streamoff kPrecisionBytes[] = {8, 4, 4, 2, 2, 1};
    const bool valid = type / 1000 == (swapped ? 1u : 0u) && type / 100 % 10 == 0 &&
                       type / 10 % 10 <= 5 && type % 10 <= 2 && rows < (1u << 31) &&
                       columns < (1u << 31) && imaginary <= 1 && name_bytes >= 1 &&
                       name_bytes < (1u << 31);
    if (!valid) {
      if (variable == 1) return std::nullopt;
      return mdr::InvalidArgument(path, "the file is corrupt: its variable number " +
                                            std::to_string(variable) + " at byte " +
                                            std::to_string(at) + " has no MAT v4 header");
    }
    // At most 2^62 elements, so the product below cannot overflow once checked against the file.
    const std::uint64_t elements = std::uint64_t{rows} * columns;
    const std::streamoff room = size - at - 20 - static_cast<std::streamoff>(name_bytes);
    const std::streamoff element_bytes = kPrecisionBytes[type / 10 % 10] * (1 + imaginary);
    if (room < 0 || elements > static_cast<std::uint64_t>(room) / element_bytes) {
      std::uint64_t declared = 0;  // up to 2^66: said as such past 2^64
      const bool overflow =
          __builtin_mul_overflow(elements, static_cast<std::uint64_t>(element_bytes), &declared) ||
          __builtin_add_overflow(declared, std::uint64_t{20} + name_bytes, &declared);
      return Truncated(path, size, variable, at,
                       overflow ? "more than 2^64" : std::to_string(declared));
    }
    at += 20 + name_bytes + static_cast<std::streamoff>(elements) * element_bytes;
  }
  return mdr::OkStatus();
}

// The inflated bytes of one compressed MAT v5 variable (a zlib stream in [begin, end) of the
// file), read forward: a window of what was inflated, its bytes before the last read dropped once
// it outgrows 1 MiB, so checking a variable of any size takes bounded memory.
class InflatedBytes {
 public:
  InflatedBytes(std::ifstream& in, std::streamoff begin, std::streamoff end)
      : in_(in), next_in_(begin), end_(end), ok_(inflateInit(&stream_) == Z_OK) {
    if (!ok_) error_ = "zlib cannot start";
  }
  ~InflatedBytes() {
    if (ok_) inflateEnd(&stream_);
  }
  InflatedBytes(const InflatedBytes&) = delete;
  InflatedBytes& operator=(const InflatedBytes&) = delete;

  // Inflates the whole stream, keeping nothing; its inflated bytes. Then ended() says whether
  // the stream ended properly, error() why not.
  std::streamoff Drain() {
    while (InflateChunk()) DropBefore(window_start_ + static_cast<std::streamoff>(window_.size()));
    return window_start_ + static_cast<std::streamoff>(window_.size());
  }
  bool ended() const { return ended_; }
  // Why the stream did not end: "" if it stopped early (cut), else zlib's message.
  const std::string& error() const { return error_; }

  // The `n` bytes at `at`, at or after the last read's; false past the end of the stream.
  bool Read(std::streamoff at, char* out, std::size_t n) {
    if (at < window_start_) return false;
    while (window_start_ + static_cast<std::streamoff>(window_.size()) <
           at + static_cast<std::streamoff>(n)) {
      DropBefore(at);
      if (!InflateChunk()) return false;
    }
    std::memcpy(out, window_.data() + (at - window_start_), n);
    DropBefore(at);
    return true;
  }

 private:
  void DropBefore(std::streamoff at) {
    const std::size_t before =
        std::min(window_.size(), static_cast<std::size_t>(at - window_start_));
    if (before < (std::size_t{1} << 20) && before < window_.size()) return;
    window_.erase(0, before);
    window_start_ += static_cast<std::streamoff>(before);
  }

  // Appends the next chunk of inflated bytes; false when the stream has no more.
  bool InflateChunk() {
    if (!error_.empty() || ended_) return false;
    if (stream_.avail_in == 0) {
      const std::streamoff chunk =
          std::min<std::streamoff>(end_ - next_in_, static_cast<std::streamoff>(input_.size()));
      if (chunk <= 0 || !in_.seekg(next_in_) ||
          !in_.read(reinterpret_cast<char*>(input_.data()), chunk)) {
        in_.clear();
        return false;
      }
      next_in_ += chunk;
      stream_.next_in = input_.data();
      stream_.avail_in = static_cast<uInt>(chunk);
    }
    unsigned char output[1 << 16];
    stream_.next_out = output;
    stream_.avail_out = sizeof output;
    const int result = inflate(&stream_, Z_NO_FLUSH);
    if (result != Z_OK && result != Z_STREAM_END) {
      if (result != Z_BUF_ERROR) {  // Z_BUF_ERROR: no progress, the stream is cut
        error_ =
            "zlib: " + (stream_.msg != nullptr ? std::string(stream_.msg) : std::to_string(result));
      }
      return false;
    }
    ended_ = result == Z_STREAM_END;
    window_.append(reinterpret_cast<const char*>(output), sizeof output - stream_.avail_out);
    return true;
  }

  std::ifstream& in_;
  std::streamoff next_in_, end_;
  z_stream stream_{};
  bool ok_, ended_ = false;
  std::string error_;
  std::vector<unsigned char> input_ = std::vector<unsigned char>(1 << 16);
  std::string window_;
  std::streamoff window_start_ = 0;
};

// A MAT v5 file is a 128-byte header and then one element per variable, each a tag (its type and
// its byte count) and that many bytes, padded to 8 unless compressed. An array's element holds
// its parts the same way (flags, dimensions, name, data; a struct's fields and a cell's elements
// are arrays in turn). matio trusts these counts: it reads a file whose last variable was cut
// short (a rig stopped while writing) without an error, the missing elements filled with whatever
// its buffer held, allocates what a corrupt count declares (a name of gigabytes, a pointer for
// every element a cell's or a struct's dimensions declare), and reads as many numbers as an
// array's dimensions declare whatever its data holds. So before matio reads anything, every
// element must end inside the file, every part inside its array, a numeric array's data must hold
// what its dimensions declare, and a cell, struct or function handle must hold an array for each
// element it declares. A compressed variable is checked the same way over its inflated bytes.
class Mat5Elements {
 public:
  explicit Mat5Elements(const std::string& path)
      : path_(path), in_(path, std::ios::binary | std::ios::ate) {}

  mdr::Status Check() {
    size_ = in_.tellg();
    char header[128];
    if (!in_ || size_ < 128 || !in_.seekg(0) || !in_.read(header, sizeof header)) {
      return mdr::InvalidArgument(path_, "cannot read the MAT v5 header");
    }
    std::uint16_t endian;
    std::memcpy(&endian, header + 126, sizeof endian);
    swapped_ = endian != ('M' << 8 | 'I');  // matio opened it: "MI" either way round
    std::streamoff at = 128;
    for (int variable = 1; at < size_; ++variable) {
      const std::optional<Tag> tag = Read(at, size_);
      if (!tag || tag->end > size_) {
        return Truncated(path_, size_, variable, at, tag ? std::to_string(tag->end - at) : "");
      }
      if (tag->type == kMatrix) {
        if (mdr::Status parts = CheckParts(at + 8, tag->end, variable, 1); !parts.ok()) {
          return parts;
        }
      }
      if (tag->type == kCompressed) {
        if (mdr::Status stream = CheckCompressed(*tag, variable); !stream.ok()) return stream;
      }
      // Padding counts from the element's start: one after a compressed variable may be unaligned.
      at = tag->type == kCompressed ? tag->end : at + Padded(tag->end - at);
    }
    return mdr::OkStatus();
  }

 private:
  static constexpr std::uint32_t kInt8 = 1;         // miINT8
  static constexpr std::uint32_t kInt32 = 5;        // miINT32
  static constexpr std::uint32_t kUint32 = 6;       // miUINT32
  static constexpr std::uint32_t kMatrix = 14;      // miMATRIX
  static constexpr std::uint32_t kCompressed = 15;  // miCOMPRESSED (its parts are zlib's)
  static constexpr int kMaxNesting = 32;

  struct Tag {
    std::uint32_t type;
    std::streamoff data;   // where its bytes start
    std::streamoff bytes;  // how many
    std::streamoff end;    // of the element, before its padding
    std::uint32_t word;    // its second word: a small element's data, else its byte count
  };
  static std::streamoff Padded(std::streamoff bytes) { return (bytes + 7) / 8 * 8; }
  // a * b, at most 2^40: more elements than any file this size holds, and no overflow.
  static std::uint64_t SaturatedProduct(std::uint64_t a, std::uint64_t b) {
    constexpr std::uint64_t kMax = std::uint64_t{1} << 40;
    std::uint64_t product;
    return __builtin_mul_overflow(a, b, &product) || product > kMax ? kMax : product;
  }

  // What an array's first parts declare, read as its parts are walked (forward, as an inflated
  // variable is read).
  struct ArrayHeader {
    std::uint32_t flags = 0;
    std::uint64_t elements = 1;           // the product of its dimensions (SaturatedProduct)
    std::uint32_t field_name_length = 0;  // a struct's bytes per field name, 0: none declared
    std::streamoff field_names_bytes = 0;
    std::uint64_t arrays = 0;  // the miMATRIX parts it holds
  };

  // A compressed variable is one zlib stream that must end within its element: matio reports a
  // corrupt one as a file without variables. Inflated once to check the stream, then walked.
  mdr::Status CheckCompressed(const Tag& tag, int variable) {
    InflatedBytes stream(in_, tag.data, tag.end);
    const std::streamoff inflated = stream.Drain();
    if (!stream.ended()) {
      return mdr::InvalidArgument(
          path_, "its variable number " + std::to_string(variable) + " (from byte " +
                     std::to_string(tag.data - 8) + ") is compressed and its data is corrupt (" +
                     (stream.error().empty() ? "its zlib stream ends early" : stream.error()) +
                     "); the file is damaged");
    }
    InflatedBytes bytes(in_, tag.data, tag.end);
    inflated_ = &bytes;
    const std::optional<Tag> array = Read(0, inflated);
    mdr::Status parts = mdr::OkStatus();
    if (array && array->end > inflated) {
      parts = Corrupt(variable, "declares " + std::to_string(array->end) +
                                    " bytes, but its data inflates to " + std::to_string(inflated));
    } else if (array && array->type == kMatrix) {
      parts = CheckParts(8, array->end, variable, 1);
    }
    inflated_ = nullptr;
    return parts;
  }

  // "the file is corrupt: its variable number N <what>".
  mdr::Status Corrupt(int variable, const std::string& what) const {
    return mdr::InvalidArgument(path_, "the file is corrupt: its variable number " +
                                           std::to_string(variable) +
                                           (inflated_ != nullptr ? " (compressed) " : " ") + what);
  }
  // The same for a `what` that names byte offsets: in a compressed variable they count its
  // inflated data, and the message says so.
  mdr::Status CorruptAt(int variable, const std::string& what) const {
    return Corrupt(variable,
                   what + (inflated_ != nullptr ? ", counting bytes of its inflated data" : ""));
  }

  std::optional<std::uint32_t> Word(std::streamoff at) {
    std::uint32_t word;
    if (inflated_ != nullptr) {
      if (!inflated_->Read(at, reinterpret_cast<char*>(&word), 4)) return std::nullopt;
    } else if (!in_.seekg(at) || !in_.read(reinterpret_cast<char*>(&word), 4)) {
      in_.clear();
      return std::nullopt;
    }
    return swapped_ ? __builtin_bswap32(word) : word;
  }

  // The tag at `at`, if the 8 bytes before `limit` hold one.
  std::optional<Tag> Read(std::streamoff at, std::streamoff limit) {
    if (limit - at < 8) return std::nullopt;
    const std::optional<std::uint32_t> type = Word(at), word = Word(at + 4);
    if (!type || !word) return std::nullopt;
    // A small element (its byte count in the type's upper half) is its 8-byte tag alone.
    if ((*type >> 16) != 0) return Tag{*type & 0xffff, at + 4, *type >> 16, at + 8, *word};
    return Tag{*type, at + 8, *word, at + 8 + *word, *word};
  }

  // The bytes of one element of a stored numeric type (0: not one).
  static std::streamoff TypeSize(std::uint32_t type) {
    switch (type) {
      case 1:  // miINT8
      case 2:  // miUINT8
        return 1;
      case 3:  // miINT16
      case 4:  // miUINT16
        return 2;
      case 5:  // miINT32
      case 6:  // miUINT32
      case 7:  // miSINGLE
        return 4;
      case 9:   // miDOUBLE
      case 12:  // miINT64
      case 13:  // miUINT64
        return 8;
      default:
        return 0;
    }
  }

  // A numeric array's real part (its parts: flags, dimensions, name, real part) holds exactly
  // what its dimensions declare: matio reads that many elements, from past the part if it holds
  // fewer. Other arrays, and parts matio would refuse anyway, are left to matio.
  mdr::Status CheckNumericData(const std::vector<Tag>& parts, const ArrayHeader& header,
                               int variable) {
    if (parts.size() < 4 || parts[0].bytes < 4) return mdr::OkStatus();
    const std::uint32_t array_class = header.flags & 0xff;
    const std::streamoff size = TypeSize(parts[3].type);
    if (array_class < 6 || array_class > 15 || size == 0) return mdr::OkStatus();  // mxDOUBLE..
    // A complex array's imaginary part (flag 0x800) holds as many elements as its real part.
    const bool complex = (header.flags & 0x800) != 0;
    const Tag* imaginary = complex && parts.size() > 4 ? &parts[4] : nullptr;
    const std::streamoff imaginary_size = imaginary ? TypeSize(imaginary->type) : 0;
    for (const auto& [part, part_size] :
         {std::pair{&parts[3], size}, std::pair{imaginary, imaginary_size}}) {
      if (part == nullptr || part_size == 0 ||
          header.elements * part_size == static_cast<std::uint64_t>(part->bytes)) {
        continue;
      }
      return Corrupt(variable, "has an array of " + std::to_string(header.elements) +
                                   " elements of " + std::to_string(part_size) +
                                   " bytes, but its data holds " + std::to_string(part->bytes) +
                                   " bytes");
    }
    return mdr::OkStatus();
  }

  // matio allocates a pointer for every element of a cell or a function handle, and for every
  // field of every element of a struct, before it reads them one array each: each must be there.
  mdr::Status CheckContainer(const ArrayHeader& header, int variable) {
    constexpr std::uint32_t kCell = 1, kStruct = 2, kFunction = 16;
    const std::uint32_t array_class = header.flags & 0xff;
    std::uint64_t declared = header.elements;
    std::string what = array_class == kCell ? "a cell of " : "a function handle of ";
    if (array_class == kStruct) {
      if (header.field_name_length == 0) return mdr::OkStatus();  // matio reads no fields
      const std::uint64_t fields =
          static_cast<std::uint64_t>(header.field_names_bytes) / header.field_name_length;
      declared = SaturatedProduct(declared, fields);
      what = "a struct of " + std::to_string(header.elements) + " elements x " +
             std::to_string(fields) + " fields, ";
    } else if (array_class != kCell && array_class != kFunction) {
      return mdr::OkStatus();
    }
    if (declared <= header.arrays) return mdr::OkStatus();
    return Corrupt(variable, "has " + what + std::to_string(declared) + " arrays, but holds " +
                                 std::to_string(header.arrays));
  }

  // The parts of the array whose data spans [begin, end), and theirs, to kMaxNesting levels.
  mdr::Status CheckParts(std::streamoff begin, std::streamoff end, int variable, int depth) {
    if (depth > kMaxNesting) {
      return Corrupt(variable,
                     "nests arrays deeper than " + std::to_string(kMaxNesting) + " levels");
    }
    std::vector<Tag> parts;  // the first five
    ArrayHeader header;
    for (std::streamoff at = begin; at < end; at = begin + Padded(at - begin)) {
      const std::optional<Tag> part = Read(at, end);
      if (!part || part->end > end) {
        return CorruptAt(variable,
                         "has a part at byte " + std::to_string(at) + " that " +
                             (part ? "declares " + std::to_string(part->end - at) + " bytes"
                                   : "has no room for its tag") +
                             ", past the end of its array at byte " + std::to_string(end));
      }
      if (part->data == at + 4 && part->bytes > 4) {
        return CorruptAt(variable, "has a part at byte " + std::to_string(at) + " that declares " +
                                       std::to_string(part->bytes) +
                                       " bytes in the 4 of a small element");
      }
      // matio reads the flags and dimensions where they should be whatever their tags say, so
      // tags that say otherwise make it read the rest from elsewhere.
      const bool misplaced =
          (parts.size() == 0 && (part->type != kUint32 || part->bytes != 8)) ||
          (parts.size() == 1 && (part->type != kInt32 || part->bytes < 8 || part->bytes % 4 != 0));
      if (misplaced) {
        return CorruptAt(variable,
                         "has " + std::string(parts.empty() ? "array flags" : "dimensions") +
                             " at byte " + std::to_string(at) + " of type " +
                             std::to_string(part->type) + " and " + std::to_string(part->bytes) +
                             " bytes, not " +
                             (parts.empty() ? "8 bytes of miUINT32"
                                            : "a multiple of 4 bytes of miINT32, at least 8"));
      }
      if (!ReadHeaderPart(parts.size(), *part, &header)) {
        return CorruptAt(variable,
                         "has a part at byte " + std::to_string(at) + " that cannot be read");
      }
      if (part->type == kMatrix) {
        ++header.arrays;
        if (mdr::Status parts = CheckParts(at + 8, part->end, variable, depth + 1); !parts.ok()) {
          return parts;
        }
      }
      // A function handle's arrays are read as variables are, a compressed one too.
      if (part->type == kCompressed && inflated_ == nullptr) {
        ++header.arrays;
        if (mdr::Status stream = CheckCompressed(*part, variable); !stream.ok()) return stream;
      }
      if (parts.size() < 5) parts.push_back(*part);
      at = part->end;
    }
    if (mdr::Status data = CheckNumericData(parts, header, variable); !data.ok()) return data;
    return CheckContainer(header, variable);
  }

  // Reads what the array's part number `index` declares into `header`, as matio reads it: the
  // flags, the dimensions, and a struct's field name length (the tag's second word, whatever its
  // size) and field names (miINT8). False if its bytes cannot be read.
  bool ReadHeaderPart(std::size_t index, const Tag& part, ArrayHeader* header) {
    if (index == 0) {
      const std::optional<std::uint32_t> flags = Word(part.data);
      if (!flags) return false;
      header->flags = *flags;
    } else if (index == 1) {
      for (std::streamoff at = part.data; at + 4 <= part.data + part.bytes; at += 4) {
        const std::optional<std::uint32_t> dim = Word(at);
        if (!dim) return false;
        header->elements = SaturatedProduct(header->elements, *dim);
      }
    } else if (index == 3 && part.type == kInt32 && part.word > 0) {
      header->field_name_length = part.word;
    } else if (index == 4 && part.type == kInt8) {
      header->field_names_bytes = part.bytes;
    }
    return true;
  }

  const std::string& path_;
  std::ifstream in_;
  std::streamoff size_ = 0;
  bool swapped_ = false;
  InflatedBytes* inflated_ = nullptr;  // while a compressed variable is walked
};

// A run variable's element as its run id: an integer in decimal (run 1000000 as "1000000", not
// "1e+06"), another number in its shortest form that reads back the same.
std::string RunId(double value) {
  if (value == std::floor(value) && std::abs(value) < 0x1p53) {
    return std::to_string(static_cast<std::int64_t>(value));  // -0 as "0"
  }
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, value).ptr;
  return std::string(text, end);
}

// The runs of the run variable, read as a selected column of `length` elements (its checks:
// a real numeric vector of finite elements, one per sample).
mdr::Result<std::vector<RigRun>> ReadRuns(mat_t* mat, const std::string& name,
                                          const SelectedColumn& first, const std::string& path,
                                          std::size_t max_samples, std::size_t length) {
  google::protobuf::RepeatedField<double> values;
  const SelectedColumn column{name, 1, &values};
  if (auto s = ReadColumn(mat, column, &first, path, max_samples, &length); !s.ok()) return s;
  RunSplitter runs;
  for (int i = 0; i < values.size(); ++i) {
    const std::string refused = runs.Add(RunId(values[i]), i + 1, "element");
    if (!refused.empty()) {
      return mdr::InvalidArgument(path, "variable " + Printable(name) + ", element " +
                                            std::to_string(i + 1) + ": " + refused);
    }
  }
  return runs.Take();
}

}  // namespace

mdr::Result<RigData> ReadRigMat(const std::string& path, const CsvLayout& layout,
                                const RigFileLimits& limits) {
  Mat_LogInitFunc("mdrctl", KeepMatioMessage);
  LastMatioMessage().clear();
  const std::string not_matlab = "cannot open as a MATLAB file (version 4, 5 or 7.3)";
  if (!HasMat5Header(path)) {
    std::optional<mdr::Status> records = CheckMat4Records(path);
    if (!records) return mdr::InvalidArgument(path, not_matlab);
    if (!records->ok()) return *records;
  }
  MatFile mat{Mat_Open(path.c_str(), MAT_ACC_RDONLY)};
  if (mat == nullptr) return mdr::InvalidArgument(path, not_matlab + MatioDetail());
  if (Mat_GetVersion(mat.get()) == MAT_FT_MAT5) {
    if (mdr::Status whole = Mat5Elements(path).Check(); !whole.ok()) return whole;
  }
  RigData data;
  data.path = path;
  data.format = RigFormat::kMat;
  const std::vector<SelectedColumn> columns = SelectColumns(layout, &data.samples);
  std::size_t length = 0;
  for (const SelectedColumn& column : columns) {
    const SelectedColumn* first = &column == &columns.front() ? nullptr : &columns.front();
    if (auto s = ReadColumn(mat.get(), column, first, path, limits.max_samples, &length); !s.ok()) {
      return s;
    }
  }
  if (!layout.run_column.empty()) {
    auto runs =
        ReadRuns(mat.get(), layout.run_column, columns.front(), path, limits.max_samples, length);
    if (!runs.ok()) return runs.status();
    data.runs = std::move(runs).value();
  }
  data.lines.resize(length);
  for (std::size_t i = 0; i < length; ++i) data.lines[i] = i + 1;
  return data;
}

}  // namespace mdrctl
