#include "geometry/surface_tet_mesher.h"

#include <glog/logging.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include "geometry/embedding.h"
#include "geometry/triangle_bvh.h"
#include "geometry/winding_number.h"
#include "mesh/element_subset.h"
#include "mesh/tet_components.h"
#include "mesh/tet_faces.h"
#include "util/disjoint_sets.h"
#include "util/option_checks.h"

namespace aqs {
namespace {

// The largest lattice this mesher builds (BCC: 12 elements per cube).
constexpr double kMaxLatticeCubes = 16e6;

// Memory per lattice element of MeshSurfaceInterior (lattice, centroids, winding
// numbers, face table, component labels). Measured as the peak resident size of
// aqs_prepare up to the end of meshing, per lattice element: 140 bytes at 735,000 and
// 126 at 2.86 million lattice elements on the finger example (about 40% of the lattice
// kept); the kept elements' face table and labels grow with the kept fraction, so a
// body that fills its box needs more.
constexpr double kBytesPerLatticeElement = 250.0;

// The most elements added to connect one component to a component it touches.
constexpr int kMaxBridgeElements = 6;

std::string Short(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// Checks the surface and the options; false with *error on the first problem.
bool CheckInput(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                const SurfaceTetMeshOptions& options, std::string* error) {
  const Eigen::Index num_vertices = vertices.cols();
  if (num_vertices == 0 || triangles.cols() == 0) {
    *error = "the surface is empty (" + std::to_string(num_vertices) + " vertices, " +
             std::to_string(triangles.cols()) + " triangles): nothing to mesh";
    return false;
  }
  for (Eigen::Index v = 0; v < num_vertices; ++v) {
    if (!vertices.col(v).allFinite()) {
      *error = "surface vertex " + std::to_string(v) + " has a non-finite coordinate (" +
               Short(vertices(0, v)) + " " + Short(vertices(1, v)) + " " + Short(vertices(2, v)) +
               ")";
      return false;
    }
  }
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) {
      if (triangles(k, t) < 0 || triangles(k, t) >= num_vertices) {
        *error = "surface triangle " + std::to_string(t) + " has vertex index " +
                 std::to_string(triangles(k, t)) + ", but the surface has " +
                 std::to_string(num_vertices) + " vertices";
        return false;
      }
    }
  }
  // The options by their one validation (this checked spacing, shell and threshold by
  // rules of its own, a winding threshold of 5 only for being finite).
  std::string options_error;
  if (!options.Validate(&options_error)) {
    *error = "surface meshing options: " + options_error;
    return false;
  }
  return true;
}

// The lattice over the surface's bounding box padded by one spacing, centred on it.
bool SurfaceLattice(const Eigen::Matrix3Xd& vertices, const SurfaceTetMeshOptions& options,
                    LatticeOptions* lattice, std::string* error) {
  const double h = options.spacing;
  const Eigen::Vector3d lo = vertices.rowwise().minCoeff();
  const Eigen::Vector3d hi = vertices.rowwise().maxCoeff();
  const Eigen::Vector3d padded = hi - lo + Eigen::Vector3d::Constant(2 * h);
  Eigen::Vector3d counts;
  for (int a = 0; a < 3; ++a) counts(a) = std::max(1.0, std::ceil(padded(a) / h));
  const double cubes = counts.prod();
  if (!(cubes <= kMaxLatticeCubes)) {
    *error = "the lattice spacing " + Short(h) + " is too small for the surface's bounding box (" +
             Short(hi(0) - lo(0)) + " x " + Short(hi(1) - lo(1)) + " x " + Short(hi(2) - lo(2)) +
             "): the lattice would have " + Short(cubes) + " cubes, more than the " +
             Short(kMaxLatticeCubes) + " this mesher builds";
    return false;
  }
  lattice->nx = static_cast<int>(counts(0));
  lattice->ny = static_cast<int>(counts(1));
  lattice->nz = static_cast<int>(counts(2));
  lattice->spacing = h;
  lattice->type = options.type;
  // Centre the slack left by rounding the counts up.
  lattice->origin = lo - Eigen::Vector3d::Constant(h) - 0.5 * (h * counts - padded);
  return true;
}

// Labels the face-connected components of the elements listed in `elements` (indices
// into lattice.tets): component[i] for elements[i], numbered from 0 in order of first
// appearance. Returns the number of components.
int FaceComponents(const TetMesh& lattice, const std::vector<int>& elements,
                   std::vector<int>* component) {
  TetMesh subset;
  subset.vertices = lattice.vertices;
  subset.tets = lattice.tets(Eigen::all, elements);
  return TetMeshPieces(subset, component);
}

// Vertex-to-element incidence: the elements using vertex v are
// elements[offsets[v] .. offsets[v + 1]), in increasing order.
struct VertexElements {
  std::vector<int> offsets;
  std::vector<int> elements;
};

VertexElements BuildVertexElements(const TetMesh& mesh) {
  VertexElements incidence;
  incidence.offsets.assign(mesh.num_vertices() + 1, 0);
  for (int t = 0; t < mesh.num_tets(); ++t) {
    for (int k = 0; k < 4; ++k) ++incidence.offsets[mesh.tets(k, t) + 1];
  }
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    incidence.offsets[v + 1] += incidence.offsets[v];
  }
  incidence.elements.resize(incidence.offsets.back());
  std::vector<int> cursor(incidence.offsets.begin(), incidence.offsets.end() - 1);
  for (int t = 0; t < mesh.num_tets(); ++t) {
    for (int k = 0; k < 4; ++k) incidence.elements[cursor[mesh.tets(k, t)]++] = t;
  }
  return incidence;
}

// The element other than t that shares t's face opposite its local vertex f, or -1.
int FaceNeighbour(const TetMesh& mesh, const VertexElements& incidence, int t, int f) {
  const int a = mesh.tets((f + 1) % 4, t), b = mesh.tets((f + 2) % 4, t),
            c = mesh.tets((f + 3) % 4, t);
  for (int i = incidence.offsets[a]; i < incidence.offsets[a + 1]; ++i) {
    const int e = incidence.elements[i];
    if (e == t) continue;
    int shared = 0;
    for (int k = 0; k < 4; ++k) shared += (mesh.tets(k, e) == b) + (mesh.tets(k, e) == c);
    if (shared == 2) return e;
  }
  return -1;
}

// Components of kept elements that touch another component only at vertices or edges
// are joined to it through shared faces: from the smallest component up, a breadth-first
// search over face neighbours finds a shortest chain of at most kMaxBridgeElements
// unkept lattice elements to another component, and the chain is kept. The set that
// holds the largest component never searches (a search from the smaller side tries the
// same chains).
//   label: per lattice element, its component (0 .. num_components - 1) or -1 when not
//          kept; added elements get a label.
// Returns the number of elements added; *num_remaining: the number of components after.
int BridgeTouchingComponents(const TetMesh& lattice, int num_components, std::vector<int>* label,
                             int* num_remaining) {
  const int num_tets = lattice.num_tets();
  std::vector<std::vector<int>> members(num_components);  // per set representative
  for (int t = 0; t < num_tets; ++t) {
    if ((*label)[t] >= 0) members[(*label)[t]].push_back(t);
  }
  std::vector<int> order(num_components);
  for (int c = 0; c < num_components; ++c) order[c] = c;
  std::stable_sort(order.begin(), order.end(),
                   [&members](int a, int b) { return members[a].size() < members[b].size(); });
  const int largest = num_components > 0 ? order.back() : -1;
  const VertexElements incidence = BuildVertexElements(lattice);
  DisjointSets sets(num_components);
  std::vector<int> stamp(num_tets, -1), parent(num_tets, -1), depth(num_tets, 0);
  int added = 0;
  for (int run = 0; run + 1 < num_components; ++run) {
    const int root = sets.Find(order[run]);
    if (root == sets.Find(largest)) continue;
    const std::vector<int>& sources = members[root];
    // Touching: some vertex is shared with an element of another component.
    bool touches = false;
    for (size_t i = 0; i < sources.size() && !touches; ++i) {
      for (int k = 0; k < 4 && !touches; ++k) {
        const int v = lattice.tets(k, sources[i]);
        for (int j = incidence.offsets[v]; j < incidence.offsets[v + 1]; ++j) {
          const int e = incidence.elements[j];
          if ((*label)[e] >= 0 && sets.Find((*label)[e]) != root) {
            touches = true;
            break;
          }
        }
      }
    }
    if (!touches) continue;
    std::vector<int> queue(sources.begin(), sources.end());
    for (int t : sources) {
      stamp[t] = run;
      depth[t] = 0;
      parent[t] = -1;
    }
    int reached = -1, last = -1;
    for (size_t head = 0; head < queue.size() && reached < 0; ++head) {
      const int t = queue[head];
      for (int f = 0; f < 4; ++f) {
        const int u = FaceNeighbour(lattice, incidence, t, f);
        if (u < 0 || stamp[u] == run) continue;
        if ((*label)[u] >= 0) {
          if (sets.Find((*label)[u]) != root) {
            reached = u;
            last = t;
            break;
          }
          continue;
        }
        if (depth[t] + 1 > kMaxBridgeElements) continue;
        stamp[u] = run;
        depth[u] = depth[t] + 1;
        parent[u] = t;
        queue.push_back(u);
      }
    }
    if (reached < 0) continue;
    for (int t = last; depth[t] > 0; t = parent[t]) {
      (*label)[t] = root;
      members[root].push_back(t);
      ++added;
    }
    const int other = sets.Find((*label)[reached]);
    sets.Union(root, other);
    const int merged = sets.Find(root);
    const int absorbed = merged == root ? other : root;
    members[merged].insert(members[merged].end(), members[absorbed].begin(),
                           members[absorbed].end());
    members[absorbed].clear();
    members[absorbed].shrink_to_fit();
  }
  *num_remaining = 0;
  for (int c = 0; c < num_components; ++c) *num_remaining += sets.Find(c) == c;
  return added;
}

}  // namespace

bool SurfaceTetMeshOptions::Validate(std::string* error) const {
  return OptionChecks()
      .Positive("spacing", spacing)
      .Require(type == LatticeType::kBcc || type == LatticeType::kKuhn, "type is not a lattice type")
      .InRange("winding_threshold", winding_threshold, -1.0, 2.0)
      .NonNegative("shell_thickness", shell_thickness)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Done(error);
}

double SurfaceTetMeshMemoryBytes(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper,
                                 const SurfaceTetMeshOptions& options, double* lattice_elements) {
  const double h = options.spacing;
  double cubes = std::numeric_limits<double>::infinity();
  if (h > 0 && std::isfinite(h) && lower.allFinite() && upper.allFinite()) {
    cubes = 1.0;
    for (int a = 0; a < 3; ++a) cubes *= std::max(1.0, std::ceil((upper[a] - lower[a] + 2 * h) / h));
  }
  const double elements = cubes * (options.type == LatticeType::kBcc ? 12.0 : 6.0);
  if (lattice_elements != nullptr) *lattice_elements = elements;
  return elements * kBytesPerLatticeElement;
}

bool MeshSurfaceInterior(const Eigen::Matrix3Xd& surface_vertices,
                         const Eigen::Matrix3Xi& surface_triangles,
                         const SurfaceTetMeshOptions& options, TetMesh* mesh, std::string* error,
                         SurfaceTetMeshStats* stats) {
  CHECK(mesh != nullptr);
  CHECK(error != nullptr);
  if (!CheckInput(surface_vertices, surface_triangles, options, error)) return false;
  LatticeOptions lattice_options;
  if (!SurfaceLattice(surface_vertices, options, &lattice_options, error)) return false;
  const TetMesh lattice = MakeLatticeMesh(lattice_options);
  const int num_lattice_tets = lattice.num_tets();
  const int num_threads = options.num_threads;

  // The winding-number test at element centroids.
  Eigen::Matrix3Xd centroids(3, num_lattice_tets);
  for (int t = 0; t < num_lattice_tets; ++t) {
    centroids.col(t) =
        0.25 *
        (lattice.vertices.col(lattice.tets(0, t)) + lattice.vertices.col(lattice.tets(1, t)) +
         lattice.vertices.col(lattice.tets(2, t)) + lattice.vertices.col(lattice.tets(3, t)));
  }
  const FastWindingNumber winding(surface_vertices, surface_triangles);
  const Eigen::VectorXd w = winding.WindingNumbers(centroids, num_threads);
  std::vector<char> inside(num_lattice_tets, 0);
  std::vector<int> passing;
  for (int t = 0; t < num_lattice_tets; ++t) {
    if (w(t) > options.winding_threshold) passing.push_back(t);
  }
  const int num_passing_winding = static_cast<int>(passing.size());
  if (options.shell_thickness > 0 && !passing.empty()) {
    Eigen::Matrix3Xd passing_centroids(3, passing.size());
    for (size_t i = 0; i < passing.size(); ++i) {
      passing_centroids.col(i) = centroids.col(passing[i]);
    }
    const TriangleBvh bvh(surface_vertices, surface_triangles);
    const std::vector<ClosestPointResult> closest =
        bvh.ClosestPoints(passing_centroids, num_threads, options.shell_thickness);
    std::vector<int> in_shell;
    for (size_t i = 0; i < passing.size(); ++i) {
      if (closest[i].triangle >= 0) in_shell.push_back(passing[i]);
    }
    passing.swap(in_shell);
  }
  if (passing.empty()) {
    std::ostringstream message;
    message << "the surface encloses nothing: ";
    if (num_passing_winding > 0) {
      message << num_passing_winding << " lattice elements have a winding number above "
              << options.winding_threshold << ", but none has its centroid within the shell "
              << "thickness " << options.shell_thickness
              << " of the surface; use a thicker shell or a smaller spacing";
    } else {
      message << "no lattice element (spacing " << options.spacing
              << ") has a winding number above " << options.winding_threshold
              << " at its centroid (the largest is " << w.maxCoeff() << ")";
      if (w.minCoeff() < -options.winding_threshold) {
        message << "; the winding numbers go down to " << w.minCoeff()
                << ", so the surface seems oriented inward: reverse its triangles";
      } else {
        message << "; an open patch (not a closed or nearly closed surface) has no inside";
      }
    }
    *error = message.str();
    return false;
  }
  for (int t : passing) inside[t] = 1;

  // The elements that hold the surface vertices.
  const Embedding embedding = EmbedPoints(lattice, surface_vertices, num_threads);
  std::vector<char> holds_vertex(num_lattice_tets, 0);
  for (int i = 0; i < embedding.num_points(); ++i) {
    CHECK_EQ(embedding.outside_distance[i], 0.0)
        << "surface vertex " << i << " is outside the padded lattice";
    holds_vertex[embedding.element[i]] = 1;
  }
  std::vector<int> kept;
  int surface_vertex_elements = 0;
  for (int t = 0; t < num_lattice_tets; ++t) {
    if (inside[t] || holds_vertex[t]) kept.push_back(t);
    if (holds_vertex[t] && !inside[t]) ++surface_vertex_elements;
  }

  // Islands: face-connected components without surface vertices, except the largest.
  std::vector<int> component;
  int num_components = FaceComponents(lattice, kept, &component);
  int dropped_components = 0;
  int dropped_elements = 0;
  std::vector<int> label(num_lattice_tets, -1);  // component of each kept element
  {
    std::vector<int> size(num_components, 0);
    std::vector<char> keep(num_components, !options.keep_largest_component);
    for (size_t i = 0; i < kept.size(); ++i) {
      ++size[component[i]];
      if (holds_vertex[kept[i]]) keep[component[i]] = 1;
    }
    // The first of the largest components (components are numbered in element order).
    keep[std::max_element(size.begin(), size.end()) - size.begin()] = 1;
    std::vector<int> new_label(num_components, -1);
    int num_kept_components = 0;
    for (int c = 0; c < num_components; ++c) {
      if (keep[c]) {
        new_label[c] = num_kept_components++;
      } else {
        ++dropped_components;
        dropped_elements += size[c];
      }
    }
    for (size_t i = 0; i < kept.size(); ++i) label[kept[i]] = new_label[component[i]];
    num_components = num_kept_components;
  }

  // Bridges between components that touch only at vertices or edges.
  int bridge_elements = 0;
  if (options.connect_touching_components) {
    bridge_elements = BridgeTouchingComponents(lattice, num_components, &label, &num_components);
  }
  kept.clear();
  for (int t = 0; t < num_lattice_tets; ++t) {
    if (label[t] >= 0) kept.push_back(t);
  }

  // Unused vertices removed, the rest renumbered in lattice order.
  *mesh = ElementSubset(lattice, kept);

  if (stats != nullptr) {
    stats->lattice_elements = num_lattice_tets;
    stats->inside_elements = static_cast<int>(passing.size());
    stats->surface_vertex_elements = surface_vertex_elements;
    stats->dropped_components = dropped_components;
    stats->dropped_elements = dropped_elements;
    stats->bridge_elements = bridge_elements;
    stats->num_components = num_components;
    stats->num_elements = mesh->num_tets();
    stats->num_vertices = mesh->num_vertices();
  }
  return true;
}

}  // namespace aqs
