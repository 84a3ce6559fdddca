// PLY writing (ASCII, with a per-vertex scalar) and point-cloud reading (PLY in all
// three formats, OBJ).

#include "mesh/ply_io.h"

#include <glog/logging.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "mesh/mesh_io.h"
#include "mesh/text_io_util.h"
#include "util/atomic_file.h"
#include "util/file_extension.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"

namespace aqs {
namespace {

using mesh_internal::Quoted;

// ---------------------------------------------------------------------------------
// Colour map.

// matplotlib's viridis at t = k/8, k = 0..8 (the 9-colour viridis palette).
constexpr std::uint8_t kViridis[9][3] = {
    {68, 1, 84},    {71, 45, 123},  {59, 82, 139},  {44, 114, 142}, {33, 144, 140},
    {39, 173, 129}, {93, 200, 99},  {170, 220, 50}, {253, 231, 37}};

// ---------------------------------------------------------------------------------
// PLY header.

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool PlyTypeFromName(const std::string& name, PlyType* type) {
  struct Named {
    const char* name;
    PlyType type;
  };
  static const Named kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const Named& named : kNames) {
    if (name == named.name) {
      *type = named.type;
      return true;
    }
  }
  return false;
}

int PlyTypeSize(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

bool IsIntegerType(PlyType type) { return type != PlyType::kFloat32 && type != PlyType::kFloat64; }

// The range of an integer type.
void IntegerRange(PlyType type, long long* lowest, long long* highest) {
  switch (type) {
    case PlyType::kInt8: *lowest = -128; *highest = 127; return;
    case PlyType::kUint8: *lowest = 0; *highest = 255; return;
    case PlyType::kInt16: *lowest = -32768; *highest = 32767; return;
    case PlyType::kUint16: *lowest = 0; *highest = 65535; return;
    case PlyType::kInt32: *lowest = -2147483648LL; *highest = 2147483647LL; return;
    default: *lowest = 0; *highest = 4294967295LL; return;  // kUint32
  }
}

// An ASCII value of `type`: an integer in the type's range for integer types; for float
// and double a decimal number (util/line_reader.h's ParseDouble) or nan, inf, -inf
// (scanners write nan for missing normals; x, y and z are checked to be finite apart).
bool ParseAsciiValue(const std::string& token, PlyType type, double* value) {
  if (!IsIntegerType(type)) {
    if (ParseDouble(token, value)) return true;
    std::string lower = token;
    for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (lower == "nan" || lower == "-nan" || lower == "+nan") {
      *value = std::numeric_limits<double>::quiet_NaN();
      return true;
    }
    if (lower == "inf" || lower == "+inf" || lower == "infinity" || lower == "+infinity") {
      *value = std::numeric_limits<double>::infinity();
      return true;
    }
    if (lower == "-inf" || lower == "-infinity") {
      *value = -std::numeric_limits<double>::infinity();
      return true;
    }
    return false;
  }
  long long integer = 0, lowest = 0, highest = 0;
  IntegerRange(type, &lowest, &highest);
  if (!ParseInt64(token, &integer) || integer < lowest || integer > highest) return false;
  *value = static_cast<double>(integer);
  return true;
}

const char* PlyTypeName(PlyType type) {
  switch (type) {
    case PlyType::kInt8: return "char";
    case PlyType::kUint8: return "uchar";
    case PlyType::kInt16: return "short";
    case PlyType::kUint16: return "ushort";
    case PlyType::kInt32: return "int";
    case PlyType::kUint32: return "uint";
    case PlyType::kFloat32: return "float";
    case PlyType::kFloat64: return "double";
  }
  return "?";
}

struct PlyProperty {
  std::string name;
  bool is_list = false;
  PlyType type = PlyType::kFloat32;        // the value type; for a list, the item type
  PlyType count_type = PlyType::kUint8;    // lists only
};

struct PlyElement {
  std::string name;
  long long count = 0;
  int line = 0;  // header line of its declaration
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
};

// Reads lines from a stream opened in binary mode, counting them (the header of every
// PLY and the data of an ASCII PLY are text; the data of a binary PLY follows the
// header's last newline in the same stream). Lines longer than kMaxLineBytes stop it
// (failed()).
class PlyLineReader {
 public:
  PlyLineReader(const std::string& path, std::istream* in) : path_(path), in_(in) {}

  // The next line (trailing '\r' removed); false at end of file, or if the line is too
  // long (then failed() is true and error() says so).
  bool NextLine(std::string* line) {
    line->clear();
    if (failed_) return false;
    std::streambuf* buffer = in_->rdbuf();
    bool any = false;
    for (int c = buffer->sbumpc(); c != std::char_traits<char>::eof(); c = buffer->sbumpc()) {
      any = true;
      if (c == '\n') break;
      if (line->size() >= static_cast<size_t>(kMaxLineBytes)) {
        failed_ = true;
        error_ = path_ + ":" + std::to_string(line_number_ + 1) + ": the line is longer than " +
                 std::to_string(kMaxLineBytes) +
                 " bytes, the longest a text line may have (not a PLY file?)";
        line->clear();
        return false;
      }
      line->push_back(static_cast<char>(c));
    }
    if (!any) return false;
    ++line_number_;
    if (!line->empty() && line->back() == '\r') line->pop_back();
    // A UTF-8 byte-order mark before "ply" is not part of the header.
    if (line_number_ == 1 && line->compare(0, 3, "\xEF\xBB\xBF") == 0) line->erase(0, 3);
    return true;
  }
  bool failed() const { return failed_; }
  const std::string& error() const { return error_; }
  // The error for a missing line: error() if the reader failed, else Where(message).
  std::string EndError(const std::string& message) const {
    return failed_ ? error_ : Where(message);
  }
  int line_number() const { return line_number_; }
  // "path:line: message" for the last line read (or `line` when given).
  std::string Where(const std::string& message, int line = -1) const {
    const int shown = line >= 0 ? line : line_number_;
    if (shown <= 0) return path_ + ": " + message;
    return path_ + ":" + std::to_string(shown) + ": " + message;
  }

 private:
  const std::string& path_;
  std::istream* in_;
  int line_number_ = 0;
  bool failed_ = false;
  std::string error_;
};

bool ReadPlyHeader(PlyLineReader* reader, PlyHeader* header, std::string* error) {
  std::string line;
  std::vector<std::string> tokens;
  if (!reader->NextLine(&line)) {
    *error = reader->EndError("not a PLY file: the file is empty");
    return false;
  }
  SplitTokens(line, '\0', &tokens);
  if (tokens.size() != 1 || tokens[0] != "ply") {
    *error = reader->Where("not a PLY file: the first line must be 'ply', got " + Quoted(line));
    return false;
  }
  bool have_format = false;
  while (true) {
    if (!reader->NextLine(&line)) {
      *error = reader->EndError(
          "the header ends without 'end_header' (the file is truncated or not a PLY file)");
      return false;
    }
    SplitTokens(line, '\0', &tokens);
    if (tokens.empty()) continue;
    const std::string& keyword = tokens[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") break;
    if (keyword == "format") {
      if (have_format) {
        *error = reader->Where("a second 'format' line");
        return false;
      }
      if (tokens.size() != 3) {
        *error = reader->Where("expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
        return false;
      }
      if (tokens[1] == "ascii") {
        header->format = PlyFormat::kAscii;
      } else if (tokens[1] == "binary_little_endian") {
        header->format = PlyFormat::kBinaryLittleEndian;
      } else if (tokens[1] == "binary_big_endian") {
        header->format = PlyFormat::kBinaryBigEndian;
      } else {
        *error = reader->Where("unknown PLY format " + Quoted(tokens[1]) +
                               " (expected ascii, binary_little_endian or binary_big_endian)");
        return false;
      }
      if (tokens[2] != "1.0" && tokens[2] != "1") {
        *error = reader->Where("unsupported PLY version " + Quoted(tokens[2]) + " (expected 1.0)");
        return false;
      }
      have_format = true;
    } else if (keyword == "element") {
      long long count = 0;
      if (tokens.size() != 3 || !ParseInt64(tokens[2], &count) || count < 0) {
        *error = reader->Where("expected 'element <name> <count>' with a count >= 0");
        return false;
      }
      PlyElement element;
      element.name = tokens[1];
      element.count = count;
      element.line = reader->line_number();
      header->elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (header->elements.empty()) {
        *error = reader->Where("a 'property' line before any 'element' line");
        return false;
      }
      PlyProperty property;
      if (tokens.size() >= 2 && tokens[1] == "list") {
        if (tokens.size() != 5) {
          *error = reader->Where("expected 'property list <count type> <item type> <name>'");
          return false;
        }
        for (int i : {2, 3}) {
          PlyType* type = i == 2 ? &property.count_type : &property.type;
          if (!PlyTypeFromName(tokens[i], type)) {
            *error = reader->Where("unsupported property type " + Quoted(tokens[i]));
            return false;
          }
        }
        if (!IsIntegerType(property.count_type)) {
          *error = reader->Where("the count type of list property " + Quoted(tokens[4]) +
                                 " must be an integer type, got " + Quoted(tokens[2]));
          return false;
        }
        property.is_list = true;
        property.name = tokens[4];
      } else {
        if (tokens.size() != 3) {
          *error = reader->Where("expected 'property <type> <name>'");
          return false;
        }
        if (!PlyTypeFromName(tokens[1], &property.type)) {
          *error = reader->Where("unsupported property type " + Quoted(tokens[1]));
          return false;
        }
        property.name = tokens[2];
      }
      header->elements.back().properties.push_back(std::move(property));
    } else {
      *error = reader->Where("unknown PLY header keyword " + Quoted(keyword));
      return false;
    }
  }
  if (!have_format) {
    *error = reader->Where("the header has no 'format' line");
    return false;
  }
  return true;
}

// Where x, y and z are among the vertex element's properties.
struct VertexLayout {
  int element = -1;
  int property[3] = {-1, -1, -1};
};

bool FindVertexLayout(const std::string& path, const PlyHeader& header, VertexLayout* layout,
                      std::string* error) {
  for (size_t e = 0; e < header.elements.size(); ++e) {
    if (header.elements[e].name == "vertex") {
      layout->element = static_cast<int>(e);
      break;
    }
  }
  if (layout->element < 0) {
    *error = path + ": no vertex element in the PLY header (expected 'element vertex <count>')";
    return false;
  }
  const PlyElement& vertex = header.elements[layout->element];
  static const char* const kAxes[3] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    for (size_t p = 0; p < vertex.properties.size(); ++p) {
      if (vertex.properties[p].name == kAxes[axis]) {
        layout->property[axis] = static_cast<int>(p);
        break;
      }
    }
    const std::string where = path + ":" + std::to_string(vertex.line) + ": ";
    if (layout->property[axis] < 0) {
      *error = where + "the vertex element has no property '" + kAxes[axis] + "'";
      return false;
    }
    if (vertex.properties[layout->property[axis]].is_list) {
      *error = where + "property '" + std::string(kAxes[axis]) +
               "' of the vertex element is a list; expected a number";
      return false;
    }
  }
  if (vertex.count > std::numeric_limits<int>::max()) {
    *error = path + ":" + std::to_string(vertex.line) + ": too many vertices (" +
             std::to_string(vertex.count) + ")";
    return false;
  }
  return true;
}

// Checks the coordinates of point i; false with *error naming the file if not finite.
bool CheckFinitePoint(const std::string& path, const double* xyz, long long i,
                      std::string* error) {
  static const char* const kAxes[3] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    if (!std::isfinite(xyz[axis])) {
      *error = path + ": vertex " + std::to_string(i) + " has a non-finite coordinate (" +
               kAxes[axis] + " = " + FormatDouble(xyz[axis]) + ")";
      return false;
    }
  }
  return true;
}

// ---------------------------------------------------------------------------------
// ASCII data.

bool ReadAsciiData(const std::string& path, const PlyHeader& header, const VertexLayout& layout,
                   long long data_bytes, PlyLineReader* reader, std::vector<double>* coordinates,
                   std::string* error) {
  std::string line;
  std::vector<std::string> tokens;
  for (size_t e = 0; e < header.elements.size(); ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = static_cast<int>(e) == layout.element;
    if (is_vertex) {
      // Each record takes at least two bytes per property: reserve no more than fits.
      const long long fits = data_bytes / (2 * std::max<long long>(1, element.properties.size()));
      coordinates->reserve(3 * static_cast<size_t>(std::min(element.count, fits)));
    }
    for (long long i = 0; i < element.count; ++i) {
      tokens.clear();
      while (tokens.empty()) {
        if (!reader->NextLine(&line)) {
          *error = reader->EndError("truncated: the file ends after " + std::to_string(i) +
                                    " of " + std::to_string(element.count) + " '" +
                                    element.name + "' records");
          return false;
        }
        SplitTokens(line, '\0', &tokens);
      }
      size_t next = 0;
      double xyz[3] = {0, 0, 0};
      for (size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        if (next >= tokens.size()) {
          *error = reader->Where("too few values in '" + element.name + "' record " +
                                 std::to_string(i) + ": no value for property '" +
                                 property.name + "'");
          return false;
        }
        if (property.is_list) {
          double length = 0;
          if (!ParseAsciiValue(tokens[next], property.count_type, &length)) {
            *error = reader->Where("expected a list length (an integer >= 0 of type " +
                                   std::string(PlyTypeName(property.count_type)) +
                                   ") for property '" + property.name + "' of '" +
                                   element.name + "' record " + std::to_string(i) + ", got " +
                                   Quoted(tokens[next]));
            return false;
          }
          const long long count = static_cast<long long>(length);
          if (count < 0) {
            *error = reader->Where("negative list length " + std::to_string(count) +
                                   " of property '" + property.name + "' in '" + element.name +
                                   "' record " + std::to_string(i));
            return false;
          }
          if (count > static_cast<long long>(tokens.size() - next - 1)) {
            *error = reader->Where("too few values in '" + element.name + "' record " +
                                   std::to_string(i) + ": list '" + property.name + "' has " +
                                   std::to_string(count) + " items");
            return false;
          }
          for (long long k = 1; k <= count; ++k) {
            double item = 0;
            if (!ParseAsciiValue(tokens[next + k], property.type, &item)) {
              *error = reader->Where("expected a value of type " +
                                     std::string(PlyTypeName(property.type)) + " in list '" +
                                     property.name + "' of '" + element.name + "' record " +
                                     std::to_string(i) + ", got " + Quoted(tokens[next + k]));
              return false;
            }
          }
          next += 1 + static_cast<size_t>(count);
          continue;
        }
        // Every value is parsed as its declared type, used or not; x, y and z must be
        // finite numbers.
        double value = 0;
        int axis_of = -1;
        for (int axis = 0; is_vertex && axis < 3; ++axis) {
          if (layout.property[axis] == static_cast<int>(p)) axis_of = axis;
        }
        if (axis_of >= 0) {
          if (!ParseDouble(tokens[next], &value) ||
              (IsIntegerType(property.type) && !ParseAsciiValue(tokens[next], property.type, &value))) {
            *error = reader->Where("expected a finite number for property '" + property.name +
                                   "' of vertex " + std::to_string(i) + ", got " +
                                   Quoted(tokens[next]));
            return false;
          }
          xyz[axis_of] = value;
          ++next;
          continue;
        }
        if (!ParseAsciiValue(tokens[next], property.type, &value)) {
          *error = reader->Where(
              "expected " +
              std::string(IsIntegerType(property.type) ? "an integer in the range of type "
                                                       : "a number of type ") +
              PlyTypeName(property.type) + " for property '" + property.name + "' of '" +
              element.name + "' record " + std::to_string(i) + ", got " + Quoted(tokens[next]));
          return false;
        }
        ++next;
      }
      if (next != tokens.size()) {
        *error = reader->Where("too many values in '" + element.name + "' record " +
                               std::to_string(i) + ": expected " + std::to_string(next) +
                               ", got " + std::to_string(tokens.size()));
        return false;
      }
      if (is_vertex) coordinates->insert(coordinates->end(), xyz, xyz + 3);
    }
  }
  // Nothing but blank lines may follow: more data than the header declares means its
  // counts are wrong, and the points beyond them would be dropped without a word.
  while (reader->NextLine(&line)) {
    SplitTokens(line, '\0', &tokens);
    if (!tokens.empty()) {
      *error = reader->Where("data after the last of the header's elements (" +
                             std::to_string(header.elements.empty()
                                                ? 0
                                                : header.elements.back().count) +
                             " '" +
                             (header.elements.empty() ? std::string()
                                                      : header.elements.back().name) +
                             "' records): the header's counts are smaller than the data");
      return false;
    }
  }
  if (reader->failed()) {
    *error = reader->error();
    return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------
// Binary data.

bool HostIsLittleEndian() {
  const std::uint16_t one = 1;
  unsigned char first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

// A scalar of `type` stored at `bytes`, byte order reversed first if `swap`.
double DecodeScalar(const unsigned char* bytes, PlyType type, bool swap) {
  unsigned char value[8];
  const int size = PlyTypeSize(type);
  for (int i = 0; i < size; ++i) value[i] = swap ? bytes[size - 1 - i] : bytes[i];
  switch (type) {
    case PlyType::kInt8: {
      std::int8_t v;
      std::memcpy(&v, value, 1);
      return v;
    }
    case PlyType::kUint8:
      return value[0];
    case PlyType::kInt16: {
      std::int16_t v;
      std::memcpy(&v, value, 2);
      return v;
    }
    case PlyType::kUint16: {
      std::uint16_t v;
      std::memcpy(&v, value, 2);
      return v;
    }
    case PlyType::kInt32: {
      std::int32_t v;
      std::memcpy(&v, value, 4);
      return v;
    }
    case PlyType::kUint32: {
      std::uint32_t v;
      std::memcpy(&v, value, 4);
      return v;
    }
    case PlyType::kFloat32: {
      float v;
      std::memcpy(&v, value, 4);
      return v;
    }
    case PlyType::kFloat64: {
      double v;
      std::memcpy(&v, value, 8);
      return v;
    }
  }
  return 0.0;
}

// Buffered reading and skipping of bytes.
class ByteReader {
 public:
  explicit ByteReader(std::istream* in) : in_(in), buffer_(1 << 20) {}

  // Copies the next n bytes to out; false if the file ends first.
  bool Read(size_t n, unsigned char* out) {
    while (n > 0) {
      if (begin_ == end_ && !Refill()) return false;
      const size_t take = std::min(n, end_ - begin_);
      std::memcpy(out, buffer_.data() + begin_, take);
      begin_ += take;
      out += take;
      n -= take;
    }
    return true;
  }

  // True if no byte is left.
  bool AtEnd() { return begin_ == end_ && !Refill(); }

  // Skips the next n bytes; false if the file ends first.
  bool Skip(unsigned long long n) {
    while (n > 0) {
      if (begin_ == end_ && !Refill()) return false;
      const size_t take = static_cast<size_t>(std::min<unsigned long long>(n, end_ - begin_));
      begin_ += take;
      n -= take;
    }
    return true;
  }

 private:
  bool Refill() {
    in_->read(reinterpret_cast<char*>(buffer_.data()), static_cast<std::streamsize>(buffer_.size()));
    begin_ = 0;
    end_ = static_cast<size_t>(in_->gcount());
    return end_ > 0;
  }

  std::istream* in_;
  std::vector<unsigned char> buffer_;
  size_t begin_ = 0;
  size_t end_ = 0;
};

bool ReadBinaryData(const std::string& path, const PlyHeader& header, const VertexLayout& layout,
                    long long data_bytes, std::istream* in, std::vector<double>* coordinates,
                    std::string* error) {
  const bool swap =
      (header.format == PlyFormat::kBinaryLittleEndian) != HostIsLittleEndian();
  ByteReader bytes(in);
  std::vector<unsigned char> record;
  for (size_t e = 0; e < header.elements.size(); ++e) {
    const PlyElement& element = header.elements[e];
    const bool is_vertex = static_cast<int>(e) == layout.element;
    auto truncated = [&](long long i) {
      *error = path + ": truncated: the file ends in element '" + element.name + "' (record " +
               std::to_string(i) + " of " + std::to_string(element.count) + ")";
      return false;
    };
    // Fixed-size records (no lists): their size and where each property starts.
    bool has_list = false;
    unsigned long long fixed_size = 0;
    std::vector<size_t> offsets;
    for (const PlyProperty& property : element.properties) {
      offsets.push_back(static_cast<size_t>(fixed_size));
      if (property.is_list) has_list = true;
      fixed_size += PlyTypeSize(property.is_list ? property.count_type : property.type);
    }
    if (is_vertex) {
      // fixed_size is a lower bound of the record size: reserve no more than fits.
      const long long fits = data_bytes / static_cast<long long>(std::max<unsigned long long>(1, fixed_size));
      coordinates->reserve(3 * static_cast<size_t>(std::min(element.count, fits)));
    }
    if (!has_list && !is_vertex) {
      // Skip the whole element at once.
      const unsigned long long count = static_cast<unsigned long long>(element.count);
      if (fixed_size > 0 && count > std::numeric_limits<unsigned long long>::max() / fixed_size) {
        return truncated(0);
      }
      if (!bytes.Skip(count * fixed_size)) return truncated(0);
      continue;
    }
    for (long long i = 0; i < element.count; ++i) {
      double xyz[3] = {0, 0, 0};
      if (!has_list) {
        record.resize(static_cast<size_t>(fixed_size));
        if (!bytes.Read(record.size(), record.data())) return truncated(i);
        for (int axis = 0; axis < 3; ++axis) {
          const int p = layout.property[axis];
          xyz[axis] = DecodeScalar(record.data() + offsets[p], element.properties[p].type, swap);
        }
      } else {
        for (size_t p = 0; p < element.properties.size(); ++p) {
          const PlyProperty& property = element.properties[p];
          unsigned char value[8];
          if (property.is_list) {
            if (!bytes.Read(PlyTypeSize(property.count_type), value)) return truncated(i);
            const double count = DecodeScalar(value, property.count_type, swap);
            if (count < 0) {
              *error = path + ": negative list length " + FormatDouble(count) + " of property '" +
                       property.name + "' in '" + element.name + "' record " + std::to_string(i);
              return false;
            }
            if (!bytes.Skip(static_cast<unsigned long long>(count) * PlyTypeSize(property.type))) {
              return truncated(i);
            }
            continue;
          }
          if (!bytes.Read(PlyTypeSize(property.type), value)) return truncated(i);
          if (is_vertex) {
            for (int axis = 0; axis < 3; ++axis) {
              if (layout.property[axis] == static_cast<int>(p)) {
                xyz[axis] = DecodeScalar(value, property.type, swap);
              }
            }
          }
        }
      }
      if (is_vertex) {
        if (!CheckFinitePoint(path, xyz, i, error)) return false;
        coordinates->insert(coordinates->end(), xyz, xyz + 3);
      }
    }
  }
  if (!bytes.AtEnd()) {
    *error = path + ": data after the last of the header's elements: the header's counts are "
                    "smaller than the data";
    return false;
  }
  return true;
}

bool ReadPly(const std::string& path, Eigen::Matrix3Xd* points, std::string* error) {
  if (!CheckInputFile(path, error)) return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = path + ": cannot open file for reading (" + std::strerror(errno) + ")";
    return false;
  }
  const long long file_size = mesh_internal::FileSizeBytes(path);
  PlyLineReader reader(path, &in);
  PlyHeader header;
  if (!ReadPlyHeader(&reader, &header, error)) return false;
  VertexLayout layout;
  if (!FindVertexLayout(path, header, &layout, error)) return false;
  const std::streamoff header_bytes = in.tellg();
  const long long data_bytes =
      file_size >= 0 && header_bytes >= 0 ? std::max<long long>(0, file_size - header_bytes) : 0;
  std::vector<double> coordinates;
  const bool ok = header.format == PlyFormat::kAscii
                      ? ReadAsciiData(path, header, layout, data_bytes, &reader, &coordinates, error)
                      : ReadBinaryData(path, header, layout, data_bytes, &in, &coordinates, error);
  if (!ok) return false;
  if (coordinates.empty()) {
    *error = path + ": the file has no points (the vertex element is empty)";
    return false;
  }
  *points = Eigen::Map<const Eigen::Matrix3Xd>(coordinates.data(), 3,
                                               static_cast<Eigen::Index>(coordinates.size() / 3));
  return true;
}

}  // namespace

double PercentileColorMax(std::vector<double> values) {
  if (values.empty()) return 1e-12;
  const auto at = values.begin() + values.size() * 95 / 100;
  std::nth_element(values.begin(), at, values.end());
  return std::max(1e-12, *at);
}

std::array<std::uint8_t, 3> ScalarColor(double value, double color_max) {
  CHECK_GT(color_max, 0.0) << "color_max must be positive";
  double t = value / color_max;
  if (!(t > 0.0)) t = 0.0;  // also NaN
  if (t > 1.0) t = 1.0;
  const double scaled = 8.0 * t;
  const int k = std::min(7, static_cast<int>(scaled));
  const double f = scaled - k;
  std::array<std::uint8_t, 3> rgb;
  for (int c = 0; c < 3; ++c) {
    const double channel = (1.0 - f) * kViridis[k][c] + f * kViridis[k + 1][c];
    rgb[c] = static_cast<std::uint8_t>(std::lround(channel));
  }
  return rgb;
}

bool WritePlyWithScalar(const std::string& path, const SurfaceMesh& surface,
                        const std::vector<double>& values, double color_max, std::string* error) {
  const int num_vertices = surface.num_vertices();
  CHECK_EQ(values.size(), static_cast<size_t>(num_vertices)) << "one value per vertex";
  CHECK_GT(color_max, 0.0) << "color_max must be positive";
  for (int v = 0; v < num_vertices; ++v) {
    if (!std::isfinite(values[v])) {
      *error = path + ": the value of vertex " + std::to_string(v) + " is not finite (" +
               FormatDouble(values[v]) + ")";
      return false;
    }
  }
  auto check_index = [num_vertices](int v) {
    CHECK(v >= 0 && v < num_vertices)
        << "surface index " << v << " out of range [0, " << num_vertices << ")";
  };
  const bool polygons = !surface.face_offsets.empty();
  int max_corners = 3;
  if (polygons) {
    CHECK_EQ(surface.face_offsets.front(), 0);
    CHECK_EQ(static_cast<size_t>(surface.face_offsets.back()), surface.face_vertices.size());
    for (int p = 0; p < surface.num_polygons(); ++p) {
      const int corners = surface.face_offsets[p + 1] - surface.face_offsets[p];
      CHECK_GE(corners, 3) << "polygon " << p << " has fewer than 3 vertices";
      max_corners = std::max(max_corners, corners);
    }
  }
  AtomicFileWriter writer(path);
  {
    mesh_internal::ChunkedWriter out(&writer.stream());
    std::string* buffer = out.buffer();
    *buffer += "ply\nformat ascii 1.0\ncomment written by ActiveQS\n";
    *buffer += "comment red green blue: viridis of value / color_max clamped to [0, 1], color_max ";
    AppendDouble(color_max, buffer);
    *buffer += "\nelement vertex ";
    mesh_internal::AppendInt(num_vertices, buffer);
    *buffer +=
        "\nproperty double x\nproperty double y\nproperty double z\n"
        "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        "property double value\nelement face ";
    mesh_internal::AppendInt(surface.num_polygons(), buffer);
    *buffer += max_corners > 255 ? "\nproperty list int int vertex_indices\n"
                                 : "\nproperty list uchar int vertex_indices\n";
    *buffer += "end_header\n";
    for (int v = 0; v < num_vertices; ++v) {
      for (int i = 0; i < 3; ++i) {
        AppendDouble(surface.vertices(i, v), buffer);
        buffer->push_back(' ');
      }
      for (std::uint8_t channel : ScalarColor(values[v], color_max)) {
        mesh_internal::AppendInt(channel, buffer);
        buffer->push_back(' ');
      }
      AppendDouble(values[v], buffer);
      buffer->push_back('\n');
      out.MaybeFlush();
    }
    if (polygons) {
      for (int p = 0; p < surface.num_polygons(); ++p) {
        mesh_internal::AppendInt(surface.face_offsets[p + 1] - surface.face_offsets[p], buffer);
        for (int i = surface.face_offsets[p]; i < surface.face_offsets[p + 1]; ++i) {
          check_index(surface.face_vertices[i]);
          buffer->push_back(' ');
          mesh_internal::AppendInt(surface.face_vertices[i], buffer);
        }
        buffer->push_back('\n');
        out.MaybeFlush();
      }
    } else {
      for (int t = 0; t < surface.num_triangles(); ++t) {
        *buffer += "3";
        for (int i = 0; i < 3; ++i) {
          check_index(surface.triangles(i, t));
          buffer->push_back(' ');
          mesh_internal::AppendInt(surface.triangles(i, t), buffer);
        }
        buffer->push_back('\n');
        out.MaybeFlush();
      }
    }
  }
  return writer.Commit(error);
}

bool ReadPointCloud(const std::string& path, Eigen::Matrix3Xd* points, std::string* error) {
  const std::string extension = LowercaseExtension(path);
  if (extension == ".ply") return ReadPly(path, points, error);
  if (extension == ".obj") {
    SurfaceMesh surface;
    if (!ReadObj(path, &surface, error)) return false;
    if (surface.num_vertices() == 0) {
      *error = path + ": the file has no points (no 'v' records)";
      return false;
    }
    *points = std::move(surface.vertices);
    return true;
  }
  *error = path + ": unknown point-cloud file extension " +
           (extension.empty() ? std::string("(none)") : Quoted(extension)) +
           " (expected .obj or .ply)";
  return false;
}

}  // namespace aqs
