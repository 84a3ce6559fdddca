// ReadTetMeshFile: choose the reader by extension; ReadTetMesh: then validate.

#include <string>

#include "mesh/mesh_io.h"
#include "mesh/tet_mesh.h"
#include "util/file_extension.h"

namespace aqs {

bool ReadTetMeshFile(const std::string& path, TetMesh* mesh, std::string* error) {
  const std::string extension = LowercaseExtension(path);
  TetMesh read;
  bool ok = false;
  if (extension == ".mesh" || extension == ".meshb") {
    ok = ReadMeditMesh(path, &read, error);
  } else if (extension == ".node" || extension == ".ele") {
    ok = ReadTetgenMesh(path, &read, error);
  } else if (extension == ".msh") {
    ok = ReadGmshMesh(path, &read, error);
  } else {
    *error = path + ": unknown mesh file extension " +
             (extension.empty() ? std::string("(none)") : "'" + extension + "'") +
             "; known: .mesh (MEDIT), .node/.ele (TetGen), .msh (Gmsh)";
    return false;
  }
  if (!ok) return false;
  *mesh = std::move(read);
  return true;
}

bool ReadTetMesh(const std::string& path, TetMesh* mesh, std::string* error) {
  TetMesh read;
  if (!ReadTetMeshFile(path, &read, error) || !ValidateTetMesh(read, path, error)) return false;
  *mesh = std::move(read);
  return true;
}

}  // namespace aqs
