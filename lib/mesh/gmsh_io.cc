// Gmsh .msh ASCII reading, formats 2.2 and 4.1.

#include <algorithm>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "mesh/mesh_io.h"
#include "mesh/text_io_util.h"
#include "util/line_reader.h"

namespace aqs {
namespace {

// Number of nodes of a Gmsh element type, or -1 for a type this reader does not know.
int GmshNodesPerElement(long long type) {
  // Types 1 to 31: lines, triangles, quadrangles, tetrahedra, hexahedra, prisms,
  // pyramids and points of orders 1 to 5 (Gmsh manual, "MSH file format").
  static const int kNodes[32] = {
      -1,                          // 0: none
      2,  3,  4,  4,  8,  6,  5,   // 1-7: line, triangle, quad, tet, hex, prism, pyramid
      3,  6,  9,  10, 27, 18, 14,  // 8-14: second-order versions
      1,                           // 15: point
      8,  20, 15, 13,              // 16-19: serendipity quad, hex, prism, pyramid
      9,  10, 12, 15, 15, 21,      // 20-25: higher-order triangles
      4,  5,  6,                   // 26-28: higher-order lines
      20, 35, 56};                 // 29-31: higher-order tetrahedra
  if (type >= 1 && type <= 31) return kNodes[type];
  if (type == 92) return 64;   // third-order hexahedron
  if (type == 93) return 125;  // fourth-order hexahedron
  return -1;
}

bool IsTet(long long type) { return type == 4 || type == 11; }

// Gmsh node tags (any positive integers) to 0-based vertex indices. Tags up to a bound
// proportional to the node count go to a flat array, larger ones to a hash map.
class NodeTagMap {
 public:
  void Reserve(long long num_nodes) {
    dense_limit_ = std::max<long long>(4 * num_nodes + 1024, 1 << 16);
  }
  // False if `tag` is already present.
  bool Insert(long long tag, int index) {
    if (tag < dense_limit_) {
      if (tag >= static_cast<long long>(dense_.size())) dense_.resize(tag + 1, -1);
      if (dense_[tag] >= 0) return false;
      dense_[tag] = index;
      return true;
    }
    return sparse_.emplace(tag, index).second;
  }
  // -1 if unknown.
  int Find(long long tag) const {
    if (tag < 0) return -1;
    if (tag < dense_limit_) return tag < static_cast<long long>(dense_.size()) ? dense_[tag] : -1;
    const auto it = sparse_.find(tag);
    return it == sparse_.end() ? -1 : it->second;
  }

 private:
  long long dense_limit_ = 1 << 16;
  std::vector<int> dense_;
  std::unordered_map<long long, int> sparse_;
};

class GmshReader {
 public:
  GmshReader(const std::string& path, LineReader* reader)
      : path_(path), reader_(reader), file_size_(mesh_internal::FileSizeBytes(path)) {}

  bool Read(TetMesh* mesh, std::string* error);

 private:
  bool Fail(const std::string& message) {
    *error_ = reader_->Where(message);
    return false;
  }
  // Reads the next non-empty line into tokens_; `what` (called only on failure) says
  // what was expected.
  template <typename What>
  bool NextLine(const What& what) {
    if (!reader_->NextTokens(&tokens_, '\0')) {
      *error_ = mesh_internal::EndOfFileError(*reader_, "expected " + what() +
                                                            ", found the end of the file");
      return false;
    }
    return true;
  }
  template <typename What>
  bool TokenInt(size_t i, const What& what, long long* value) {
    if (!ParseInt64(tokens_[i], value)) {
      return Fail("expected " + what() + " (an integer), got " + Quoted(tokens_[i]));
    }
    return true;
  }
  template <typename What>
  bool TokenDouble(size_t i, const What& what, double* value) {
    if (!ParseDouble(tokens_[i], value)) {
      return Fail("expected " + what() + " (a finite number), got " + Quoted(tokens_[i]));
    }
    return true;
  }
  // The current line must have exactly `count` tokens.
  template <typename What>
  bool ExpectTokens(size_t count, const What& what) {
    if (tokens_.size() != count) {
      return Fail("expected " + what() + " (" + std::to_string(count) + " entries), got " +
                  std::to_string(tokens_.size()) + " entries");
    }
    return true;
  }
  bool ExpectEnd(const std::string& end_marker, const std::string& after);
  bool ReadMeshFormat();
  bool ReadNodes2();
  bool ReadNodes4();
  bool ReadElements2();
  bool ReadElements4();
  bool AddNode(long long tag, int index);
  // Converts the node tags tokens_[first .. first + count) of an element on the current
  // line; for tets, appends the 4 corner indices to tets_.
  bool AddElement(long long element_tag, long long type, size_t first, int count);
  bool SkipSection(const std::string& name);

  std::string path_;
  LineReader* reader_;
  long long file_size_;
  std::string* error_ = nullptr;
  std::vector<std::string> tokens_;
  bool version4_ = false;
  bool have_format_ = false;
  bool have_nodes_ = false;
  bool have_elements_ = false;
  NodeTagMap tags_;
  std::vector<double> coordinates_;
  std::vector<int> tets_;
  long long num_other_elements_ = 0;
};

bool GmshReader::ExpectEnd(const std::string& end_marker, const std::string& after) {
  if (!NextLine([&] { return end_marker + " after " + after; })) return false;
  if (tokens_.size() != 1 || tokens_[0] != end_marker) {
    return Fail("expected " + end_marker + " after " + after + ", got " + Quoted(reader_->line()) +
                " (is the count in the section header right?)");
  }
  return true;
}

bool GmshReader::ReadMeshFormat() {
  if (!NextLine([] { return std::string("'version file-type data-size' after $MeshFormat"); }) ||
      !ExpectTokens(3, [] { return std::string("'version file-type data-size'"); })) {
    return false;
  }
  const std::string& version = tokens_[0];
  long long file_type = 0;
  if (!TokenInt(
          1, [] { return std::string("the file type (0 = ASCII)"); }, &file_type)) {
    return false;
  }
  if (file_type != 0) {
    return Fail("binary Gmsh files (file type " + tokens_[1] +
                ") are not supported; save the mesh as ASCII (Gmsh: Mesh.Binary = 0)");
  }
  if (version == "4.1") {
    version4_ = true;
  } else if (version == "2.2" || version == "2.1" || version == "2.0" || version == "2") {
    version4_ = false;
  } else {
    return Fail("unsupported Gmsh format version " + Quoted(version) +
                " (supported: 2.2 and 4.1; Gmsh: Mesh.MshFileVersion)");
  }
  if (!ExpectEnd("$EndMeshFormat", "the format line")) return false;
  have_format_ = true;
  return true;
}

bool GmshReader::AddNode(long long tag, int index) {
  if (tag <= 0) return Fail("node tags must be positive integers, got " + std::to_string(tag));
  if (!tags_.Insert(tag, index)) {
    return Fail("node tag " + std::to_string(tag) + " appears twice in $Nodes");
  }
  return true;
}

bool GmshReader::ReadNodes2() {
  long long count = 0;
  if (!NextLine([] { return std::string("the number of nodes after $Nodes"); }) ||
      !ExpectTokens(1, [] { return std::string("the number of nodes"); }) ||
      !TokenInt(
          0, [] { return std::string("the number of nodes"); }, &count) ||
      !mesh_internal::CheckRecordCount(*reader_, count, 4, file_size_, "nodes", error_)) {
    return false;
  }
  tags_.Reserve(count);
  coordinates_.resize(static_cast<size_t>(count) * 3);
  for (long long n = 0; n < count; ++n) {
    auto what = [&] {
      return "node " + std::to_string(n + 1) + " of " + std::to_string(count) + " ('tag x y z')";
    };
    if (!NextLine(what) || !ExpectTokens(4, what)) return false;
    long long tag = 0;
    if (!TokenInt(
            0, [] { return std::string("the node tag"); }, &tag) ||
        !AddNode(tag, static_cast<int>(n))) {
      return false;
    }
    for (int i = 0; i < 3; ++i) {
      if (!TokenDouble(
              i + 1, [] { return std::string("a node coordinate"); }, &coordinates_[3 * n + i])) {
        return false;
      }
    }
  }
  return ExpectEnd("$EndNodes", std::to_string(count) + " nodes");
}

bool GmshReader::ReadNodes4() {
  static const char kHeader[] = "'numEntityBlocks numNodes minNodeTag maxNodeTag'";
  long long num_blocks = 0, count = 0, min_tag = 0, max_tag = 0;
  if (!NextLine([] { return std::string(kHeader) + " after $Nodes"; }) ||
      !ExpectTokens(4, [] { return std::string(kHeader); }) ||
      !TokenInt(
          0, [] { return std::string("numEntityBlocks"); }, &num_blocks) ||
      !TokenInt(
          1, [] { return std::string("numNodes"); }, &count) ||
      !TokenInt(
          2, [] { return std::string("minNodeTag"); }, &min_tag) ||
      !TokenInt(
          3, [] { return std::string("maxNodeTag"); }, &max_tag) ||
      !mesh_internal::CheckRecordCount(*reader_, num_blocks, 4, file_size_, "node blocks",
                                       error_) ||
      !mesh_internal::CheckRecordCount(*reader_, count, 4, file_size_, "nodes", error_)) {
    return false;
  }
  tags_.Reserve(count);
  coordinates_.resize(static_cast<size_t>(count) * 3);
  long long read = 0;
  for (long long b = 0; b < num_blocks; ++b) {
    static const char kBlock[] = "'entityDim entityTag parametric numNodesInBlock'";
    auto what = [&] {
      return "node block " + std::to_string(b + 1) + " of " + std::to_string(num_blocks) + " " +
             kBlock;
    };
    long long dim = 0, entity = 0, parametric = 0, in_block = 0;
    if (!NextLine(what) || !ExpectTokens(4, what) ||
        !TokenInt(
            0, [] { return std::string("entityDim"); }, &dim) ||
        !TokenInt(
            1, [] { return std::string("entityTag"); }, &entity) ||
        !TokenInt(
            2, [] { return std::string("parametric (0 or 1)"); }, &parametric) ||
        !TokenInt(
            3, [] { return std::string("numNodesInBlock"); }, &in_block)) {
      return false;
    }
    if (in_block < 0 || in_block > count - read) {
      return Fail("node block " + std::to_string(b + 1) + " has " + std::to_string(in_block) +
                  " nodes but the $Nodes header announces " + std::to_string(count) +
                  " in all and " + std::to_string(read) + " were already read");
    }
    // Tags: one per line in files Gmsh writes; accepted spread over lines however.
    long long tags_read = 0;
    while (tags_read < in_block) {
      if (!NextLine([&] {
            return "node tag " + std::to_string(tags_read + 1) + " of " + std::to_string(in_block) +
                   " in node block " + std::to_string(b + 1);
          })) {
        return false;
      }
      if (static_cast<long long>(tokens_.size()) > in_block - tags_read) {
        return Fail("expected " + std::to_string(in_block - tags_read) +
                    " more node tags in node block " + std::to_string(b + 1) + ", got " +
                    std::to_string(tokens_.size()) + " entries");
      }
      for (size_t i = 0; i < tokens_.size(); ++i, ++tags_read) {
        long long tag = 0;
        if (!TokenInt(
                i, [] { return std::string("a node tag"); }, &tag) ||
            !AddNode(tag, static_cast<int>(read + tags_read))) {
          return false;
        }
      }
    }
    for (long long n = 0; n < in_block; ++n) {
      auto what_xyz = [&] {
        return "the coordinates 'x y z" + std::string(parametric ? " u ..." : "") + "' of node " +
               std::to_string(n + 1) + " of " + std::to_string(in_block) + " in node block " +
               std::to_string(b + 1);
      };
      if (!NextLine(what_xyz)) return false;
      if (tokens_.size() < 3 || (parametric == 0 && tokens_.size() != 3) || tokens_.size() > 6) {
        return Fail("expected " + what_xyz() + ", got " + std::to_string(tokens_.size()) +
                    " entries");
      }
      for (int i = 0; i < 3; ++i) {
        if (!TokenDouble(
                i, [] { return std::string("a node coordinate"); },
                &coordinates_[3 * (read + n) + i])) {
          return false;
        }
      }
    }
    read += in_block;
  }
  if (read != count) {
    return Fail("the node blocks hold " + std::to_string(read) +
                " nodes but the $Nodes header announces " + std::to_string(count));
  }
  return ExpectEnd("$EndNodes", std::to_string(count) + " nodes");
}

bool GmshReader::AddElement(long long element_tag, long long type, size_t first, int count) {
  for (int i = 0; i < count; ++i) {
    long long tag = 0;
    if (!TokenInt(
            first + i, [] { return std::string("a node tag"); }, &tag))
      return false;
    const int index = tags_.Find(tag);
    if (index < 0) {
      return Fail("element " + std::to_string(element_tag) + " refers to node tag " +
                  std::to_string(tag) + " which is not in $Nodes");
    }
    if (IsTet(type) && i < 4) tets_.push_back(index);
  }
  if (!IsTet(type)) ++num_other_elements_;
  return true;
}

bool GmshReader::ReadElements2() {
  long long count = 0;
  if (!NextLine([] { return std::string("the number of elements after $Elements"); }) ||
      !ExpectTokens(1, [] { return std::string("the number of elements"); }) ||
      !TokenInt(
          0, [] { return std::string("the number of elements"); }, &count) ||
      !mesh_internal::CheckRecordCount(*reader_, count, 4, file_size_, "elements", error_)) {
    return false;
  }
  for (long long e = 0; e < count; ++e) {
    auto what = [&] {
      return "element " + std::to_string(e + 1) + " of " + std::to_string(count) +
             " ('tag type number-of-tags tags... nodes...')";
    };
    if (!NextLine(what)) return false;
    if (tokens_.size() < 3) {
      return Fail("expected " + what() + ", got " + std::to_string(tokens_.size()) + " entries");
    }
    long long tag = 0, type = 0, num_tags = 0;
    if (!TokenInt(
            0, [] { return std::string("the element tag"); }, &tag) ||
        !TokenInt(
            1, [] { return std::string("the element type"); }, &type) ||
        !TokenInt(
            2, [] { return std::string("the number of tags"); }, &num_tags)) {
      return false;
    }
    const int nodes = GmshNodesPerElement(type);
    if (nodes < 0) {
      return Fail("element " + std::to_string(tag) + " has unknown element type " +
                  std::to_string(type));
    }
    if (num_tags < 0 || num_tags > static_cast<long long>(tokens_.size())) {
      return Fail("element " + std::to_string(tag) + " has an invalid number of tags " +
                  std::to_string(num_tags));
    }
    const size_t expected = 3 + static_cast<size_t>(num_tags) + nodes;
    if (tokens_.size() != expected) {
      return Fail("element " + std::to_string(tag) + " of type " + std::to_string(type) + " with " +
                  std::to_string(num_tags) + " tags needs " + std::to_string(expected) +
                  " entries (3 + tags + " + std::to_string(nodes) + " nodes), got " +
                  std::to_string(tokens_.size()));
    }
    for (long long i = 0; i < num_tags; ++i) {
      long long value = 0;
      if (!TokenInt(
              3 + i, [] { return std::string("an element tag (physical/entity)"); }, &value)) {
        return false;
      }
    }
    if (!AddElement(tag, type, 3 + static_cast<size_t>(num_tags), nodes)) return false;
  }
  return ExpectEnd("$EndElements", std::to_string(count) + " elements");
}

bool GmshReader::ReadElements4() {
  static const char kHeader[] = "'numEntityBlocks numElements minElementTag maxElementTag'";
  long long num_blocks = 0, count = 0, min_tag = 0, max_tag = 0;
  if (!NextLine([] { return std::string(kHeader) + " after $Elements"; }) ||
      !ExpectTokens(4, [] { return std::string(kHeader); }) ||
      !TokenInt(
          0, [] { return std::string("numEntityBlocks"); }, &num_blocks) ||
      !TokenInt(
          1, [] { return std::string("numElements"); }, &count) ||
      !TokenInt(
          2, [] { return std::string("minElementTag"); }, &min_tag) ||
      !TokenInt(
          3, [] { return std::string("maxElementTag"); }, &max_tag) ||
      !mesh_internal::CheckRecordCount(*reader_, num_blocks, 4, file_size_, "element blocks",
                                       error_) ||
      !mesh_internal::CheckRecordCount(*reader_, count, 2, file_size_, "elements", error_)) {
    return false;
  }
  long long read = 0;
  for (long long b = 0; b < num_blocks; ++b) {
    static const char kBlock[] = "'entityDim entityTag elementType numElementsInBlock'";
    auto what = [&] {
      return "element block " + std::to_string(b + 1) + " of " + std::to_string(num_blocks) + " " +
             kBlock;
    };
    long long dim = 0, entity = 0, type = 0, in_block = 0;
    if (!NextLine(what) || !ExpectTokens(4, what) ||
        !TokenInt(
            0, [] { return std::string("entityDim"); }, &dim) ||
        !TokenInt(
            1, [] { return std::string("entityTag"); }, &entity) ||
        !TokenInt(
            2, [] { return std::string("elementType"); }, &type) ||
        !TokenInt(
            3, [] { return std::string("numElementsInBlock"); }, &in_block)) {
      return false;
    }
    const int nodes = GmshNodesPerElement(type);
    if (nodes < 0) {
      return Fail("element block " + std::to_string(b + 1) + " has unknown element type " +
                  std::to_string(type));
    }
    if (in_block < 0 || in_block > count - read) {
      return Fail("element block " + std::to_string(b + 1) + " has " + std::to_string(in_block) +
                  " elements but the $Elements header announces " + std::to_string(count) +
                  " in all and " + std::to_string(read) + " were already read");
    }
    if (IsTet(type)) tets_.reserve(tets_.size() + 4 * static_cast<size_t>(in_block));
    for (long long e = 0; e < in_block; ++e) {
      auto what_element = [&] {
        return "element " + std::to_string(e + 1) + " of " + std::to_string(in_block) +
               " in element block " + std::to_string(b + 1) + " ('tag' and " +
               std::to_string(nodes) + " node tags for type " + std::to_string(type) + ")";
      };
      if (!NextLine(what_element) || !ExpectTokens(1 + static_cast<size_t>(nodes), what_element)) {
        return false;
      }
      long long tag = 0;
      if (!TokenInt(
              0, [] { return std::string("the element tag"); }, &tag) ||
          !AddElement(tag, type, 1, nodes)) {
        return false;
      }
    }
    read += in_block;
  }
  if (read != count) {
    return Fail("the element blocks hold " + std::to_string(read) +
                " elements but the $Elements header announces " + std::to_string(count));
  }
  return ExpectEnd("$EndElements", std::to_string(count) + " elements");
}

bool GmshReader::SkipSection(const std::string& name) {
  const int start_line = reader_->line_number();
  const std::string end_marker = "$End" + name.substr(1);
  while (reader_->NextLine()) {
    // Only the start of the line matters; avoid splitting long lines.
    const std::string& line = reader_->line();
    const size_t begin = line.find_first_not_of(" \t");
    if (begin != std::string::npos && line.compare(begin, end_marker.size(), end_marker) == 0) {
      const size_t rest = begin + end_marker.size();
      if (rest == line.size() || line.find_first_not_of(" \t", rest) == std::string::npos) {
        return true;
      }
    }
  }
  if (!reader_->ok()) {
    *error_ = reader_->error();
    return false;
  }
  *error_ = path_ + ":" + std::to_string(start_line) + ": section " + name + " is not closed: no " +
            end_marker + " before the end of the file";
  return false;
}

bool GmshReader::Read(TetMesh* mesh, std::string* error) {
  error_ = error;
  while (reader_->NextTokens(&tokens_, '\0')) {
    const std::string name = tokens_[0];
    if (name.empty() || name[0] != '$' || tokens_.size() != 1) {
      return Fail("expected the start of a section such as $Nodes, got " + Quoted(reader_->line()));
    }
    if (!have_format_ && name != "$MeshFormat") {
      return Fail("expected $MeshFormat at the start of a Gmsh file, got " + Quoted(name));
    }
    if (name == "$MeshFormat") {
      if (have_format_) return Fail("a second $MeshFormat section");
      if (!ReadMeshFormat()) return false;
    } else if (name == "$Nodes") {
      if (have_nodes_) return Fail("a second $Nodes section (only one is supported)");
      if (!(version4_ ? ReadNodes4() : ReadNodes2())) return false;
      have_nodes_ = true;
    } else if (name == "$Elements") {
      if (!have_nodes_) return Fail("$Elements before $Nodes");
      if (have_elements_) return Fail("a second $Elements section (only one is supported)");
      if (!(version4_ ? ReadElements4() : ReadElements2())) return false;
      have_elements_ = true;
    } else if (name.compare(0, 4, "$End") == 0) {
      return Fail("unexpected " + Quoted(name) + " outside of its section");
    } else {
      if (!SkipSection(name)) return false;
    }
  }
  if (!reader_->ok()) {
    *error = reader_->error();
    return false;
  }
  if (!have_format_) {
    *error = path_ + ": empty file (expected a Gmsh mesh starting with $MeshFormat)";
    return false;
  }
  if (!have_nodes_) {
    *error = path_ + ": no $Nodes section";
    return false;
  }
  if (tets_.empty()) {
    *error = path_ + ": no tetrahedra (element types 4 or 11) in the file" +
             (have_elements_
                  ? " (it has " + std::to_string(num_other_elements_) + " elements of other types)"
                  : std::string(": no $Elements section"));
    return false;
  }
  const int num_vertices = static_cast<int>(coordinates_.size() / 3);
  mesh->vertices = Eigen::Map<const Eigen::Matrix3Xd>(coordinates_.data(), 3, num_vertices);
  mesh->tets = Eigen::Map<const Eigen::Matrix4Xi>(tets_.data(), 4,
                                                  static_cast<Eigen::Index>(tets_.size() / 4));
  return true;
}

}  // namespace

bool ReadGmshMesh(const std::string& path, TetMesh* mesh, std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  GmshReader gmsh(path, &reader);
  return gmsh.Read(mesh, error);
}

}  // namespace aqs
