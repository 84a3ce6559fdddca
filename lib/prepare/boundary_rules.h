#ifndef AQS_PREPARE_BOUNDARY_RULES_H_
#define AQS_PREPARE_BOUNDARY_RULES_H_

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "mesh/surface_mesh.h"
#include "mesh/tet_mesh.h"
#include "model/active_model.h"

namespace aqs {

// A bone: a rigid surface (e.g. the lower teeth) whose per-pose motion drives the
// fixed simulation vertices of a region (e.g. the jaw).
struct BoneRule {
  std::string name;
  // The bone surface at rest (OBJ).
  std::string neutral_mesh;
  // Its per-pose surfaces, same vertex order: "{pose}" in the pattern is replaced by
  // the pose name (e.g. "faces/{pose}.teeth.obj"). A pose without such a file keeps
  // the bone at rest.
  std::string pose_mesh_pattern;
  // The transform is fitted (least squares) to the bone vertices that move: those whose
  // largest displacement over all poses exceeds this fraction of the largest of all.
  // (A file holding both jaws' teeth thus yields the lower jaw's motion.)
  double moving_fraction = 0.1;
  // The fixed vertices (selected by the fixed rules) inside any of these boxes are
  // driven by this bone instead of staying at rest.
  std::vector<Eigen::AlignedBox3d> region_boxes;
};

// Which simulation vertices are fixed. A vertex is fixed if any rule selects it; then
// a bone whose region contains it drives it (the first such bone), else it stays at
// rest.
struct BoundaryRuleOptions {
  // Vertices inside the surface (winding number > 0.5) and farther than this from it
  // (> 0 to use).
  double fixed_depth = -1.0;
  // Vertices inside any of these boxes.
  std::vector<Eigen::AlignedBox3d> fixed_boxes;
  // Vertices inside any of these closed surfaces (OBJ; winding number > 0.5).
  std::vector<std::string> fixed_inside_meshes;
  // An explicit vertex list file (io/vertex_list_io.h, plain indices), in the numbering
  // ApplyBoundaryRules is given (prepare: that of --tet_mesh's file).
  std::string fixed_list;
  std::vector<BoneRule> bones;
  // Static fixed vertices (fixed by the rules above but driven by no bone) within this
  // distance of a bone-driven vertex are left free (0: none). A bone that moves next to
  // static vertices otherwise shears the one layer of elements between them (a jaw that
  // opens by 25 degrees moves its deep vertices about 3 cm from static neighbours 1 cm
  // away): their volumetric targets degenerate and their equilibria invert. The clearance
  // gives that tissue room to deform.
  double bone_clearance = 0.0;
  int num_threads = 2;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// The numbering a vertex list (BoundaryRuleOptions::fixed_list) is written in, when it
// is not the simulation mesh's own: that of the mesh file before prepare cropped, pruned
// and cut it.
struct ListNumbering {
  int num_vertices = 0;     // the file's vertex count
  std::vector<int> origin;  // per simulation vertex, its index in the file
};

// Applies the rules to the simulation mesh (`surface`: the neutral surface, for depth)
// and fills model->static_vertices and model->bones (with one transform per name in
// pose_names). list_numbering: the numbering of options.fixed_list (a listed vertex
// fixes every vertex of `mesh` that comes from it, its cut copies too); null: fixed_list
// indexes `mesh` itself. Appends a human-readable summary to *log.
// Returns false with *error if a file cannot be read, a listed vertex is out of range or
// has no vertex in `mesh` (removed; the message names it), a bone's pose surface has the
// wrong vertex count, or no vertex ends up fixed (an unconstrained body has no unique
// equilibrium).
bool ApplyBoundaryRules(const BoundaryRuleOptions& options, const TetMesh& mesh,
                        const SurfaceMesh& surface, const std::vector<std::string>& pose_names,
                        const ListNumbering* list_numbering, ActiveModel* model,
                        std::string* log, std::string* error);

// Parses "xmin,ymin,zmin,xmax,ymax,zmax" (the box must not be empty). Returns false with
// *error quoting the text.
bool ParseBox(const std::string& text, Eigen::AlignedBox3d* box, std::string* error);

}  // namespace aqs

#endif  // AQS_PREPARE_BOUNDARY_RULES_H_
