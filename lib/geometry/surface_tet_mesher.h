#ifndef AQS_GEOMETRY_SURFACE_TET_MESHER_H_
#define AQS_GEOMETRY_SURFACE_TET_MESHER_H_

#include <string>

#include <Eigen/Core>

#include "mesh/lattice.h"
#include "mesh/tet_mesh.h"

namespace aqs {

struct SurfaceTetMeshOptions {
  double spacing = 1.0;                     // lattice cube edge (> 0)
  LatticeType type = LatticeType::kBcc;     // from mesh/lattice.h
  double winding_threshold = 0.5;           // element kept if the winding number at its centroid
                                            // exceeds this
  double shell_thickness = 0.0;             // > 0: keep only elements whose centroid is within
                                            // this distance of the surface
  bool keep_largest_component = true;       // drop face-disconnected islands not containing
                                            // surface vertices
  bool connect_touching_components = true;  // join components that touch only at vertices
                                            // or edges through shared faces (see below)
  int num_threads = 2;

  // Checks every field; false with *error naming the first bad one.
  bool Validate(std::string* error) const;
};

// The memory MeshSurfaceInterior needs for the lattice over a surface with this
// bounding box (lower and upper corners) and `options` (bytes; an estimate from the
// lattice's element count, 250 bytes per lattice element: measured 126 to 140 on a
// body that fills 40% of its lattice), and that element count (*lattice_elements, may
// be null). Infinite for a spacing that is not positive and finite.
double SurfaceTetMeshMemoryBytes(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                                 const SurfaceTetMeshOptions& options,
                                 double* lattice_elements = nullptr);

// What MeshSurfaceInterior did.
struct SurfaceTetMeshStats {
  int lattice_elements = 0;  // elements of the whole lattice
  int inside_elements = 0;   // passing the winding-number test (and the shell test)
  // Elements kept only because they contain a surface vertex (they failed the tests).
  int surface_vertex_elements = 0;
  int dropped_components = 0;  // islands dropped by keep_largest_component
  int dropped_elements = 0;    // their elements
  // Elements added to join components that touched only at vertices or edges.
  int bridge_elements = 0;
  int num_components = 0;  // face-connected components of the result
  int num_elements = 0;    // in the result
  int num_vertices = 0;    // in the result
};

// Tet mesh covering the inside of `surface` (vertices 3 x N, triangles 3 x M, 0-based):
// a lattice (options.type, cube edge options.spacing) over the surface's bounding box
// padded by one spacing on every side; an element is kept if the generalized winding
// number of the surface (FastWindingNumber, default options) at its centroid exceeds
// options.winding_threshold (and, with a shell, if its centroid is within
// options.shell_thickness of the surface), and ALSO the element EmbedPoints assigns to
// each surface vertex is kept, so every surface vertex lies in an element of the result
// (on shared faces one containing element is enough). The surface is expected to be
// oriented with outward normals; holes are fine (that is what winding numbers are for).
// With keep_largest_component, components of kept elements (connected through shared
// faces) that contain no surface-vertex element are dropped, except the largest.
// An element kept for a surface vertex often hangs on the rest by a vertex or an edge
// only, which would leave it free to rotate in a simulation; with
// connect_touching_components, every component that shares a vertex with another one
// is joined to it by the lattice elements of a shortest chain of face neighbours (at
// most 6 elements; from the smallest component up), so that the result is one
// face-connected piece wherever the kept elements touch (stats->num_components says how
// many pieces remain; separate surfaces stay separate).
// Unused lattice vertices are removed and the rest renumbered in lattice order;
// elements keep the lattice's order and positive orientation.
// Returns false with *error (and leaves *mesh unchanged) if the surface is empty, has a
// non-finite coordinate or an index out of range, the options are invalid
// (SurfaceTetMeshOptions::Validate; or the lattice too large for the spacing), or the surface
// encloses nothing (no element passes the winding-number and shell tests: a flat open
// patch, an inward-oriented surface, a shell too thin). `stats` may be null.
bool MeshSurfaceInterior(const Eigen::Matrix3Xd& surface_vertices,
                         const Eigen::Matrix3Xi& surface_triangles,
                         const SurfaceTetMeshOptions& options, TetMesh* mesh, std::string* error,
                         SurfaceTetMeshStats* stats = nullptr);

}  // namespace aqs

#endif  // AQS_GEOMETRY_SURFACE_TET_MESHER_H_
