// Point-cloud reading (ply_io.h's ReadPointCloud): PLY in all three formats, OBJ.

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "mesh/mesh_io.h"
#include "mesh/ply_format.h"
#include "mesh/ply_io.h"
#include "mesh/text_io_util.h"
#include "util/file_extension.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"

namespace aqs {
namespace {

using mesh_internal::IsIntegerType;
using mesh_internal::ParseAsciiValue;
using mesh_internal::PlyElement;
using mesh_internal::PlyFormat;
using mesh_internal::PlyHeader;
using mesh_internal::PlyLineReader;
using mesh_internal::PlyProperty;
using mesh_internal::PlyType;
using mesh_internal::PlyTypeName;
using mesh_internal::PlyTypeSize;
using mesh_internal::ReadPlyHeader;

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
