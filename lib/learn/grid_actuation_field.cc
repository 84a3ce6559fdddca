#include "learn/grid_actuation_field.h"
#include "util/option_checks.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <glog/logging.h>

namespace aqs {
namespace {

// A centroid may lie this far (in units of the spacing) outside its cell (round-off).
constexpr double kCellTolerance = 1e-9;

Eigen::Vector3d Centroid(const TetMesh& mesh, int e) {
  return 0.25 * (mesh.vertices.col(mesh.tets(0, e)) + mesh.vertices.col(mesh.tets(1, e)) +
                 mesh.vertices.col(mesh.tets(2, e)) + mesh.vertices.col(mesh.tets(3, e)));
}

int64_t GridIndex(const Eigen::Vector3i& dims, int64_t i, int64_t j, int64_t k) {
  return i + dims[0] * (j + dims[1] * k);
}

// The 8 grid indices (corner c = dx + 2 dy + 4 dz of the cell) and trilinear weights of
// point p. Returns false if p lies outside the grid.
bool CellWeights(const GridFieldDescription& grid, const Eigen::Vector3d& p,
                 int64_t indices[8], double weights[8]) {
  int64_t cell[3];
  double fraction[3];
  for (int a = 0; a < 3; ++a) {
    const double u = (p[a] - grid.origin[a]) / grid.spacing;
    const double lower = std::floor(u);
    const double max_cell = grid.grid_dims[a] - 2;
    const double c = std::min(std::max(lower, 0.0), max_cell);
    const double f = u - c;
    if (!(f >= -kCellTolerance && f <= 1.0 + kCellTolerance)) return false;
    cell[a] = static_cast<int64_t>(c);
    fraction[a] = std::min(std::max(f, 0.0), 1.0);
  }
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1;
    const int dy = (corner >> 1) & 1;
    const int dz = (corner >> 2) & 1;
    indices[corner] = GridIndex(grid.grid_dims, cell[0] + dx, cell[1] + dy, cell[2] + dz);
    weights[corner] = (dx ? fraction[0] : 1.0 - fraction[0]) *
                      (dy ? fraction[1] : 1.0 - fraction[1]) *
                      (dz ? fraction[2] : 1.0 - fraction[2]);
  }
  return true;
}

}  // namespace

bool GridActuationFieldOptions::Validate(std::string* error) const {
  return OptionChecks()
      .NonNegative("node_spacing", node_spacing)
      .Positive("node_spacing_factor", node_spacing_factor)
      .Done(error);
}

bool PlanGridActuationField(const TetMesh& mesh, const GridActuationFieldOptions& options,
                            double* max_nodes, std::string* error) {
  if (!options.Validate(error)) return false;
  const double num_elements = mesh.num_tets();
  if (options.per_element) {
    if (max_nodes != nullptr) *max_nodes = num_elements;
    return true;
  }
  const bool by_factor = !(options.node_spacing > 0.0);
  const double spacing = by_factor ? options.node_spacing_factor * MeanEdgeLength(mesh)
                                   : options.node_spacing;
  const char* field = by_factor ? "node_spacing_factor" : "node_spacing";
  const double value = by_factor ? options.node_spacing_factor : options.node_spacing;
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    *error = std::string(field) + " " + OptionValue(value) + " gives the control grid a spacing of " +
             OptionValue(spacing) + "; it must be positive and finite";
    return false;
  }
  const Eigen::Vector3d lower = mesh.vertices.rowwise().minCoeff();
  const Eigen::Vector3d upper = mesh.vertices.rowwise().maxCoeff();
  double grid_nodes = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::max(1.0, std::ceil((upper[a] - lower[a]) / spacing));
    if (!(cells < 1e6)) {
      std::ostringstream out;
      out << field << " " << OptionValue(value) << " gives the control grid a spacing of "
          << OptionValue(spacing) << ", " << OptionValue(cells) << " cells along "
          << "xyz"[a] << " for a mesh extent of " << OptionValue(upper[a] - lower[a])
          << " (at most 1e6 per axis); use a larger spacing";
      *error = out.str();
      return false;
    }
    grid_nodes *= cells + 1.0;
  }
  // The model reader refuses larger grids (LoadDecoder): a model must load once saved.
  if (grid_nodes > kMaxGridNodes) {
    std::ostringstream out;
    out << field << " " << OptionValue(value) << " gives the control grid a spacing of "
        << OptionValue(spacing) << ", " << OptionValue(grid_nodes) << " grid nodes (at most "
        << OptionValue(kMaxGridNodes) << "); use a larger spacing";
    *error = out.str();
    return false;
  }
  if (max_nodes != nullptr) *max_nodes = std::min(grid_nodes, 8.0 * num_elements);
  return true;
}

GridActuationField::GridActuationField(const TetMesh& mesh,
                                       const GridActuationFieldOptions& options) {
  CHECK_GT(mesh.num_tets(), 0);
  description_.num_elements = mesh.num_tets();
  if (options.per_element) {
    description_.per_element = true;
    return;
  }
  const double spacing = options.node_spacing > 0.0
                             ? options.node_spacing
                             : options.node_spacing_factor * MeanEdgeLength(mesh);
  CHECK(spacing > 0.0 && std::isfinite(spacing)) << "node spacing " << spacing;
  const Eigen::Vector3d lower = mesh.vertices.rowwise().minCoeff();
  const Eigen::Vector3d upper = mesh.vertices.rowwise().maxCoeff();
  description_.spacing = spacing;
  for (int a = 0; a < 3; ++a) {
    const double extent = upper[a] - lower[a];
    const double cells = std::max(1.0, std::ceil(extent / spacing));
    CHECK_LT(cells, 1e6) << "node spacing " << spacing << " is far too small for a mesh "
                         << "extent of " << extent;
    description_.grid_dims[a] = static_cast<int>(cells) + 1;
    description_.origin[a] = lower[a] - 0.5 * (cells * spacing - extent);
  }
  // Kept nodes: those with a positive weight on some element, in grid-index order.
  std::vector<int64_t> kept;
  kept.reserve(static_cast<size_t>(mesh.num_tets()) * 8);
  int64_t indices[8];
  double weights[8];
  for (int e = 0; e < mesh.num_tets(); ++e) {
    CHECK(CellWeights(description_, Centroid(mesh, e), indices, weights))
        << "centroid of element " << e << " outside its own bounding box";
    for (int c = 0; c < 8; ++c) {
      if (weights[c] > 0.0) kept.push_back(indices[c]);
    }
  }
  std::sort(kept.begin(), kept.end());
  kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
  kept.shrink_to_fit();
  const int64_t nx = description_.grid_dims[0];
  const int64_t ny = description_.grid_dims[1];
  description_.nodes.resize(3, static_cast<Eigen::Index>(kept.size()));
  for (size_t n = 0; n < kept.size(); ++n) {
    description_.nodes(0, n) = static_cast<int>(kept[n] % nx);
    description_.nodes(1, n) = static_cast<int>((kept[n] / nx) % ny);
    description_.nodes(2, n) = static_cast<int>(kept[n] / (nx * ny));
  }
  std::string error;
  CHECK(ComputeWeights(mesh, kept, "grid", &error)) << error;
}

bool GridActuationField::FromDescription(const TetMesh& mesh,
                                         const GridFieldDescription& description,
                                         const std::string& source, GridActuationField* field,
                                         std::string* error) {
  if (mesh.num_tets() != description.num_elements) {
    std::ostringstream out;
    out << source << ": the actuation field is for " << description.num_elements
        << " elements, the mesh has " << mesh.num_tets();
    *error = out.str();
    return false;
  }
  GridActuationField result;
  result.description_ = description;
  if (description.per_element) {
    result.description_.nodes.resize(3, 0);
    *field = std::move(result);
    return true;
  }
  CHECK(description.spacing > 0.0 && (description.grid_dims.array() >= 2).all())
      << "invalid grid description";
  std::vector<int64_t> kept(description.nodes.cols());
  for (Eigen::Index n = 0; n < description.nodes.cols(); ++n) {
    const Eigen::Vector3i ijk = description.nodes.col(n);
    CHECK((ijk.array() >= 0).all() && (ijk.array() < description.grid_dims.array()).all())
        << "grid node " << n << " outside the grid";
    kept[n] = GridIndex(description.grid_dims, ijk[0], ijk[1], ijk[2]);
    CHECK(n == 0 || kept[n] > kept[n - 1]) << "grid nodes must be in increasing grid order";
  }
  if (!result.ComputeWeights(mesh, kept, source, error)) return false;
  *field = std::move(result);
  return true;
}

bool GridActuationField::ComputeWeights(const TetMesh& mesh, const std::vector<int64_t>& kept,
                                        const std::string& source, std::string* error) {
  const int num_elements = mesh.num_tets();
  nodes_.resize(8, num_elements);
  weights_.resize(8, num_elements);
  int64_t indices[8];
  double weights[8];
  for (int e = 0; e < num_elements; ++e) {
    const Eigen::Vector3d centroid = Centroid(mesh, e);
    if (!CellWeights(description_, centroid, indices, weights)) {
      std::ostringstream out;
      out << source << ": the centroid of element " << e << " (" << centroid.transpose()
          << ") lies outside the actuation field's grid; the mesh does not match";
      *error = out.str();
      return false;
    }
    int first_node = -1;
    for (int c = 0; c < 8; ++c) {
      int node = -1;
      if (weights[c] > 0.0) {
        const auto it = std::lower_bound(kept.begin(), kept.end(), indices[c]);
        if (it == kept.end() || *it != indices[c]) {
          std::ostringstream out;
          out << source << ": element " << e << " needs grid node " << indices[c]
              << " (grid index), which the actuation field does not keep; the mesh does "
                 "not match";
          *error = out.str();
          return false;
        }
        node = static_cast<int>(it - kept.begin());
        if (first_node < 0) first_node = node;
      }
      nodes_(c, e) = node;
      weights_(c, e) = weights[c];
    }
    CHECK_GE(first_node, 0);  // the weights sum to 1
    for (int c = 0; c < 8; ++c) {
      if (nodes_(c, e) < 0) nodes_(c, e) = first_node;
    }
  }
  return true;
}

Eigen::Vector3d GridActuationField::NodePosition(int n) const {
  CHECK(!per_element()) << "a per-element field has no node positions";
  CHECK(n >= 0 && n < num_nodes());
  return description_.origin + description_.spacing * description_.nodes.col(n).cast<double>();
}

void GridActuationField::Interpolate(const Eigen::Ref<const NodeValueMatrix>& node_values,
                                     ActuationMatrix* out) const {
  CHECK_EQ(node_values.cols(), num_nodes());
  if (per_element()) {
    *out = node_values;
    return;
  }
  out->resize(6, num_elements());
  for (int e = 0; e < num_elements(); ++e) {
    Vector6d sum = weights_(0, e) * node_values.col(nodes_(0, e));
    for (int c = 1; c < 8; ++c) sum += weights_(c, e) * node_values.col(nodes_(c, e));
    out->col(e) = sum;
  }
}

void GridActuationField::Apply(const Eigen::Ref<const NodeValueMatrix>& node_values,
                               ActuationMatrix* out) const {
  Interpolate(node_values, out);
  out->colwise() += IdentityActuation();
}

void GridActuationField::ApplyTranspose(const Eigen::Ref<const ActuationMatrix>& da,
                                        NodeValueMatrix* node_gradient) const {
  CHECK_EQ(da.cols(), num_elements());
  if (per_element()) {
    *node_gradient = da;
    return;
  }
  node_gradient->setZero(6, num_nodes());
  for (int e = 0; e < num_elements(); ++e) {
    const Vector6d g = da.col(e);
    for (int c = 0; c < 8; ++c) node_gradient->col(nodes_(c, e)) += weights_(c, e) * g;
  }
}

}  // namespace aqs
