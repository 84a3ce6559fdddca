// The PLY header and its value types (ply_format.h).

#include "mesh/ply_format.h"

#include <cctype>
#include <limits>
#include <string>
#include <vector>

#include "mesh/text_io_util.h"
#include "util/line_reader.h"

namespace aqs {
namespace mesh_internal {

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
        *error = reader->Where(
            "expected 'format <ascii|binary_little_endian|binary_big_endian> 1.0'");
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

}  // namespace mesh_internal
}  // namespace aqs
