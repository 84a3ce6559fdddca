#ifndef AQS_MESH_MESH_IO_H_
#define AQS_MESH_MESH_IO_H_

#include <string>
#include <vector>

#include "mesh/surface_mesh.h"
#include "mesh/tet_mesh.h"

namespace aqs {

// All readers return false and set *error on failure. Messages name the file and,
// for content errors, the 1-based line and what was expected there, e.g.
//   "a.mesh:17: expected 4 vertex indices and a reference after 'Tetrahedra', got 3 tokens".
// Readers only parse: they check indices are in range but do not judge geometry
// (ReadTetMesh does, through ValidateTetMesh). On failure the output is left unchanged.
// Header counts that are negative or larger than the file can hold are errors (no
// allocation is made for them). Readers take linear time in the file size. Only
// regular files are read (a FIFO or a device is refused, util/input_file.h), lines are
// at most kMaxLineBytes (1 MiB) long, and numbers are decimal (no hexadecimal, nan or
// inf; util/line_reader.h's ParseDouble).

// MEDIT ASCII .mesh (keywords MeshVersionFormatted, Dimension 3, Vertices,
// Tetrahedra; the sections Triangles, Edges, Corners, Ridges, RequiredVertices,
// RequiredEdges, Quadrilaterals, Hexahedra, Normals, NormalAtVertices, Tangents,
// TangentAtVertices are skipped; an unknown keyword is an error naming it). Indices in
// the file are 1-based. Binary .meshb is rejected with a message saying so.
// Details: records may span lines and '#' starts a comment; keywords are
// case-sensitive; Prisms, Pyramids and Required{Triangles,Quadrilaterals,Tetrahedra,
// Hexahedra} are skipped too; Dimension, if present, must be 3; Vertices and Tetrahedra must each
// appear exactly once (in either order); a missing final End is tolerated and anything
// after End is ignored.
bool ReadMeditMesh(const std::string& path, TetMesh* mesh, std::string* error);

// TetGen .node/.ele. `path` may name the .node file, the .ele file or their common
// stem; both files must exist (T.NODE goes with T.ELE: an extension given in upper case
// is looked for in upper case; a stem alone, in lower case). Index base (0 or 1) is
// taken from the first .node entry as TetGen does; attributes and boundary markers are
// parsed (finite numbers) and not used. 10-node elements keep their 4 corner nodes (the
// mid-edge points stay unused vertices, as in ReadGmshMesh). Points and tetrahedra must be
// numbered consecutively from the base, node indices must name points of the .node
// file, and nothing but comments may follow the records the headers count; '#' starts
// a comment. Point lines may omit trailing attributes/markers.
bool ReadTetgenMesh(const std::string& path, TetMesh* mesh, std::string* error);

// Gmsh .msh ASCII, format 2.2 or 4.1 (read from $MeshFormat). Node tags may be any
// positive integers (non-contiguous is fine); elements of type 4 (4-node tet) and 11
// (10-node tet, corners kept: its mid-edge nodes stay vertices that no element uses,
// which aqs_prepare drops and aqs_simulate refuses) become tets; other element types are
// skipped. Binary
// files are rejected with a message saying so.
// Details: node tags become 0-based vertex indices in order of appearance (nodes
// used by no tet are kept as vertices); an element type whose node count is unknown,
// an element node tag missing from $Nodes, a duplicated node tag, counts that
// disagree with the section and a missing $End<Section> are errors; unknown sections
// ($PhysicalNames, $Entities, $NodeData, ...) are skipped; a file without tets is an
// error. Version 2.x (ASCII 2.0-2.2) and 4.1 are read; 4.0 and 1.0 are not.
bool ReadGmshMesh(const std::string& path, TetMesh* mesh, std::string* error);

// Reads a tet mesh by extension (.mesh, .node, .ele, .msh), then validates it with
// ValidateTetMesh. Unknown extensions are an error listing the known ones.
bool ReadTetMesh(const std::string& path, TetMesh* mesh, std::string* error);

// The parsing half of ReadTetMesh, without the geometric validation: for files that
// hold deformed states of a known mesh (targets, warm starts), whose elements may be
// inverted.
bool ReadTetMeshFile(const std::string& path, TetMesh* mesh, std::string* error);

// Wavefront OBJ surface: 'v x y z [w]' and 'f' records with 'i', 'i/t', 'i//n', 'i/t/n'
// corners; negative (relative) indices are resolved; polygons are kept in
// face_offsets/face_vertices and fan-triangulated into `triangles`. Other records
// (vt, vn, g, o, s, usemtl, mtllib, l, ...) are ignored. Faces with fewer than 3
// corners or out-of-range indices are errors naming the line; a face that repeats a
// vertex is kept as it is (zero-area triangles: scanners write them, and a scan read as
// a point cloud through this reader must not fail on its faces).
// Details: 'v' may carry w or an r g b colour after x y z (ignored); a positive index
// may refer to a vertex defined later in the file (checked at the end); face_offsets,
// face_vertices and triangle_face are filled whenever the file has faces.
bool ReadObj(const std::string& path, SurfaceMesh* surface, std::string* error);

// Writers. Every number reads back bit for bit (util/number_format.h); files are written
// atomically (temporary file, then rename). Return false with *error on failure. The
// MEDIT, OBJ and PLY writers refuse a vertex with a non-finite coordinate, naming it
// (the readers refuse nan and inf, so such a file could not be read back); VTU, for
// viewers only, writes them as nan and inf.

// MEDIT ASCII .mesh (MeshVersionFormatted 2) with the vertices and tets of `mesh`
// in the same order (1-based in the file, references 0).
bool WriteMeditMesh(const std::string& path, const TetMesh& mesh, std::string* error);

// OBJ with `surface`'s vertices and its polygons (or triangles when it has none).
// The first line is "# written by ActiveQS"; indices are written 1-based. Indices out
// of range are a programmer error (CHECK).
bool WriteObj(const std::string& path, const SurfaceMesh& surface, std::string* error);

// A named data array for VTU output. `values` holds `components` numbers per entry,
// entry after entry (for a vector field: x0 y0 z0 x1 y1 z1 ...); the number of entries
// must be the vertex count (point data) or element count (cell data).
struct VtuField {
  std::string name;
  int components = 1;
  std::vector<double> values;
};

// VTK XML unstructured grid (.vtu, ASCII, readable by ParaView) of `mesh` with
// per-vertex and per-element fields. Field sizes are checked (CHECK: programmer error).
// Points and fields are Float64, connectivity and offsets Int64, types UInt8 (10 =
// tetra); VTU file version 0.1. Field names are XML-escaped. A point or field value
// that is not finite is refused (false, *error naming the vertex or the field and entry;
// nothing is written).
bool WriteVtu(const std::string& path, const TetMesh& mesh,
              const std::vector<VtuField>& point_fields,
              const std::vector<VtuField>& cell_fields, std::string* error);

}  // namespace aqs

#endif  // AQS_MESH_MESH_IO_H_
