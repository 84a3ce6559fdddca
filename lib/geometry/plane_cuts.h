#ifndef AQS_GEOMETRY_PLANE_CUTS_H_
#define AQS_GEOMETRY_PLANE_CUTS_H_

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "geometry/embedding.h"
#include "mesh/tet_mesh.h"

namespace aqs {

// A cut through a lattice mesh, limited to a region: the side of a point p is + where
//   normal . p + quadratic . (p_x^2, p_y^2, p_z^2) >= offset,
// - elsewhere (a plane when quadratic = 0, else a simple curved surface). Used where two parts of a surface touch or
// nearly touch and must move apart (the lips of a closed mouth, the lids of an eye),
// which elements larger than the gap would otherwise bind together.
struct PlaneCut {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();
  Eigen::Vector3d quadratic = Eigen::Vector3d::Zero();
  double offset = 0.0;
  Eigen::AlignedBox3d region;  // only elements whose centroid is inside are cut
};

// The result of cutting: the new mesh (original vertices first, in order, then ghost
// copies), and per element of the new mesh, for every cut, the side it belongs to (+1,
// -1, or 0 if that cut does not split it) and its twin (the element that is the other
// side's copy of the same original element, or -1).
struct CutMesh {
  TetMesh mesh;
  std::vector<int> original_vertex;              // per vertex: the vertex it copies
  std::vector<std::vector<int>> element_side;    // [cut][element]
  std::vector<std::vector<int>> element_twin;    // [cut][element]
};

// Duplicates the elements crossed by each cut inside its region, in the manner of the
// virtual node algorithm (Molino, Bao and Fedkiw 2004): an element with vertices on both
// sides becomes two elements at the same place, the + copy made of its + vertices and
// "ghost" copies of its - vertices, the - copy the other way round; ghosts are shared by
// all copies on the same side, so each side stays a conforming mesh, and the two sides
// are joined only outside the region. Cuts apply one after another: an element two cuts
// split has four copies, each with its twin across either cut (the copy on the same side
// of the other cut). Elements keep their orientation; original element e is element e of
// the result (its + copy if cut).
CutMesh ApplyPlaneCuts(const TetMesh& mesh, const std::vector<PlaneCut>& cuts);

// Moves each embedded point that lies in a cut's region to the copy of its element on
// the point's own side of that cut (the twin has the same geometry, so the weights
// stay). points: the embedded points at rest (3 x num_points). The side of a point is
// the sign of f(p) = normal . p + quadratic . p^2 - offset, except within `margin`
// (distance estimated as |f| / |grad f|) of the cut when outward surface normals are
// given (3 x num_points, or empty): a surface point there faces into the slit the cut
// separates, so its material, and its side, is opposite to its normal
// (sign(-n . grad f)). Returns how many points moved.
int AssignEmbeddingSides(const CutMesh& cut_mesh, const std::vector<PlaneCut>& cuts,
                         const Eigen::Matrix3Xd& points, const Eigen::Matrix3Xd& normals,
                         double margin, Embedding* embedding);

// Parses "nx,ny,nz,offset[,qx,qy,qz]@xmin,ymin,zmin,xmax,ymax,zmax" (q: the quadratic
// coefficients, default 0). Returns false with *error.
bool ParsePlaneCut(const std::string& text, PlaneCut* cut, std::string* error);

}  // namespace aqs

#endif  // AQS_GEOMETRY_PLANE_CUTS_H_
