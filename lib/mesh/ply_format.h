// The PLY header and its value types, for the PLY reader (ply_reader.cc): the format,
// the elements with their properties, a line reader that counts lines, and the parsing
// of the header and of one ASCII value. Internal to lib/mesh.

#ifndef AQS_MESH_PLY_FORMAT_H_
#define AQS_MESH_PLY_FORMAT_H_

#include <istream>
#include <string>
#include <vector>

#include "util/input_file.h"

namespace aqs {
namespace mesh_internal {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

// The type of a PLY type name ("char" or "int8", ..., "double" or "float64"); false if
// the name is none of them.
bool PlyTypeFromName(const std::string& name, PlyType* type);

// The size of a value of `type` in a binary PLY, in bytes (1, 2, 4 or 8).
int PlyTypeSize(PlyType type);

// True for the integer types (all but float and double).
bool IsIntegerType(PlyType type);

// The range of an integer type.
void IntegerRange(PlyType type, long long* lowest, long long* highest);

// An ASCII value of `type`: an integer in the type's range for integer types; for float
// and double a decimal number (util/line_reader.h's ParseDouble) or nan, inf, -inf
// (scanners write nan for missing normals; x, y and z are checked to be finite apart).
bool ParseAsciiValue(const std::string& token, PlyType type, double* value);

// The type's PLY name ("char", "uchar", ..., "double"), for messages.
const char* PlyTypeName(PlyType type);

struct PlyProperty {
  std::string name;
  bool is_list = false;
  PlyType type = PlyType::kFloat32;      // the value type; for a list, the item type
  PlyType count_type = PlyType::kUint8;  // lists only
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

// Reads the header from its first line ("ply") to "end_header" into *header: the format
// line, the elements and their properties in order ('comment' and 'obj_info' lines are
// skipped). False with *error naming the file and line ("scan.ply:3: ...") for a file
// that is not a PLY, an unknown format or type, a malformed line, or a missing
// end_header or format.
bool ReadPlyHeader(PlyLineReader* reader, PlyHeader* header, std::string* error);

}  // namespace mesh_internal
}  // namespace aqs

#endif  // AQS_MESH_PLY_FORMAT_H_
