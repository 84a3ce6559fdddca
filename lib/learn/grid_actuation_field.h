#ifndef AQS_LEARN_GRID_ACTUATION_FIELD_H_
#define AQS_LEARN_GRID_ACTUATION_FIELD_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mesh/mesh_measures.h"
#include "mesh/tet_mesh.h"
#include "physics/actuation.h"

namespace aqs {

// Control-node values: 6 x num_nodes, column n the six numbers (sxx syy szz sxy sxz syz)
// of node n, column-major (node n starts at data() + 6 n), like ActuationMatrix.
using NodeValueMatrix = Eigen::Matrix<double, 6, Eigen::Dynamic>;


struct GridActuationFieldOptions {
  // Distance between neighbouring control nodes along x, y and z, in mesh units.
  // If <= 0, node_spacing_factor x MeanEdgeLength(mesh) is used.
  double node_spacing = 0.0;
  double node_spacing_factor = 4.0;
  // Skip the grid: one node per element (node e = element e, identity interpolation).
  bool per_element = false;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Everything needed to rebuild a field for a mesh (what decoder files store):
//   per_element: one node per element (nothing else below is used but num_elements);
//   origin:      position of grid node (0, 0, 0);
//   spacing:     distance between neighbouring nodes (same along x, y, z);
//   grid_dims:   nodes along x, y, z (grid node (i, j, k) sits at origin + spacing (i, j, k));
//   nodes:       3 x num_nodes grid coordinates (i, j, k) of the kept nodes; column n is
//                control node n. Sorted by the grid index i + nx (j + ny k), increasing.
struct GridFieldDescription {
  bool per_element = false;
  int num_elements = 0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double spacing = 0.0;
  Eigen::Vector3i grid_dims = Eigen::Vector3i::Zero();
  Eigen::Matrix3Xi nodes;

  int num_nodes() const { return per_element ? num_elements : static_cast<int>(nodes.cols()); }
};

// The most grid nodes (product of grid_dims) a field may have: the decoder reader
// refuses more as implausible, so PlanGridActuationField refuses to plan more.
constexpr double kMaxGridNodes = 1e15;

// The grid GridActuationField(mesh, options) would build, planned without building it:
// *max_nodes (may be null) is an upper bound of its control nodes (the element count
// for per_element; else the smaller of the grid's node count and 8 per element).
// Returns false with *error, naming the option that sets the spacing (node_spacing, or
// node_spacing_factor when node_spacing is 0), if the spacing is not positive and
// finite, the grid would need 1e6 cells or more along an axis (which the constructor
// CHECKs), or more than kMaxGridNodes nodes. `mesh` needs at least one element.
bool PlanGridActuationField(const TetMesh& mesh, const GridActuationFieldOptions& options,
                            double* max_nodes, std::string* error);

// A linear map from a few control-node values to all element actuations, written
// around the identity:
//
//   a_e = I + sum_k w_ek v_{n_ek}      (six numbers per element and node),
//
// where element e's centroid gets the trilinear weights w_ek (k = 0..7, non-negative,
// summing to 1) of the 8 nodes n_ek of the grid cell that contains it. The grid is
// regular over the mesh's bounding box (centred, so it overhangs equally on both
// sides), and only the nodes with a positive weight on some element are kept, numbered
// 0 .. num_nodes()-1 in increasing grid index. A field linear in position is
// reproduced exactly at the centroids.
//
// With GridActuationFieldOptions::per_element, node e is element e: a = I + v.
//
// Storage: 8 int32 node indices + 8 double weights = 96 bytes per element (24 MB at
// 250,000 elements); nothing for per_element. Apply and ApplyTranspose cost 48
// multiply-adds per element (about 1 ms at 250,000 elements).
//
// Immutable after construction; thread-safe.
class GridActuationField {
 public:
  // An empty field (0 elements, 0 nodes), to be assigned.
  GridActuationField() = default;
  // Builds the grid for `mesh` (at least one element; CHECKs a positive spacing).
  GridActuationField(const TetMesh& mesh, const GridActuationFieldOptions& options);

  // Rebuilds the field `description` describes for `mesh` (e.g. from a decoder file).
  // Fails, with *error prefixed by `source` (a file name), if the mesh does not match:
  // a different element count, a centroid outside the grid, or an element that needs
  // a grid node the description does not keep. Weights are recomputed from the mesh,
  // so the same mesh and description give a bit-for-bit identical field.
  static bool FromDescription(const TetMesh& mesh, const GridFieldDescription& description,
                              const std::string& source, GridActuationField* field,
                              std::string* error);

  bool per_element() const { return description_.per_element; }
  int num_elements() const { return description_.num_elements; }
  int num_nodes() const { return description_.num_nodes(); }
  const GridFieldDescription& description() const { return description_; }

  // Position of control node n (a grid field only).
  Eigen::Vector3d NodePosition(int n) const;
  // Node indices (8 x num_elements) and weights (8 x num_elements) of a grid field:
  // column e holds element e's eight nodes and their trilinear weights. Entries with
  // weight 0 repeat a node of that element. Empty for per_element.
  const Eigen::Matrix<int32_t, 8, Eigen::Dynamic>& element_nodes() const { return nodes_; }
  const Eigen::Matrix<double, 8, Eigen::Dynamic>& element_weights() const { return weights_; }

  // out = I + Interpolate(node_values) for node_values 6 x num_nodes(); *out is resized
  // to 6 x num_elements().
  void Apply(const Eigen::Ref<const NodeValueMatrix>& node_values, ActuationMatrix* out) const;
  // The linear part alone: out_e = sum_k w_ek v_{n_ek} (6 x num_elements()). Used for
  // directions (Jacobian columns), where the identity does not belong.
  void Interpolate(const Eigen::Ref<const NodeValueMatrix>& node_values,
                   ActuationMatrix* out) const;
  // The adjoint of Interpolate (and the derivative of Apply): for da = dL/da
  // (6 x num_elements()), sets *node_gradient (resized to 6 x num_nodes()) to dL/dv,
  // node n receiving sum over elements e, slots k with n_ek = n of w_ek da_e.
  void ApplyTranspose(const Eigen::Ref<const ActuationMatrix>& da,
                      NodeValueMatrix* node_gradient) const;

 private:
  // Computes nodes_ and weights_ for `mesh` on description_'s grid, where control node
  // n is the grid node with grid index kept[n] (increasing). See FromDescription for
  // the errors.
  bool ComputeWeights(const TetMesh& mesh, const std::vector<int64_t>& kept,
                      const std::string& source, std::string* error);

  GridFieldDescription description_;
  Eigen::Matrix<int32_t, 8, Eigen::Dynamic> nodes_;
  Eigen::Matrix<double, 8, Eigen::Dynamic> weights_;
};

}  // namespace aqs

#endif  // AQS_LEARN_GRID_ACTUATION_FIELD_H_
