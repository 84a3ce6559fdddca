#include "mesh/lattice.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include <glog/logging.h>

namespace aqs {
namespace {

void AddTet(int a, int b, int c, int d, std::vector<int>* tets) {
  tets->push_back(a);
  tets->push_back(b);
  tets->push_back(c);
  tets->push_back(d);
}

// Kuhn split of the cube (i, j, k): one element per ordering of the axes, along the
// path (0,0,0) -> +e_p0 -> +e_p1 -> (1,1,1).
void AddKuhnCube(const LatticeOptions& o, int i, int j, int k, std::vector<int>* tets) {
  const int cx = o.nx + 1, cy = o.ny + 1;
  int corner[8];  // bit 0: +x, bit 1: +y, bit 2: +z
  for (int b = 0; b < 8; ++b) {
    corner[b] = (i + (b & 1)) + cx * ((j + ((b >> 1) & 1)) + cy * (k + ((b >> 2) & 1)));
  }
  static const int kAxisOrders[6][3] = {{1, 2, 4}, {1, 4, 2}, {2, 1, 4},
                                        {2, 4, 1}, {4, 1, 2}, {4, 2, 1}};
  for (const auto& order : kAxisOrders) {
    AddTet(corner[0], corner[order[0]], corner[order[0] | order[1]], corner[7], tets);
  }
}

// BCC elements around the cube faces perpendicular to `axis`.
void AddBccFaces(const LatticeOptions& o, int axis, int num_corners, std::vector<int>* tets) {
  const int n[3] = {o.nx, o.ny, o.nz};
  const int u = (axis + 1) % 3, w = (axis + 2) % 3;
  auto corner = [&](const int p[3]) { return p[0] + (o.nx + 1) * (p[1] + (o.ny + 1) * p[2]); };
  auto centre = [&](const int p[3]) { return num_corners + p[0] + o.nx * (p[1] + o.ny * p[2]); };
  for (int s = 0; s <= n[axis]; ++s) {
    for (int b = 0; b < n[w]; ++b) {
      for (int a = 0; a < n[u]; ++a) {
        int q[4];
        static const int kSquare[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (int m = 0; m < 4; ++m) {
          int p[3];
          p[axis] = s;
          p[u] = a + kSquare[m][0];
          p[w] = b + kSquare[m][1];
          q[m] = corner(p);
        }
        int cube[3];
        cube[u] = a;
        cube[w] = b;
        if (s > 0 && s < n[axis]) {
          cube[axis] = s - 1;
          const int before = centre(cube);
          cube[axis] = s;
          const int after = centre(cube);
          for (int m = 0; m < 4; ++m) AddTet(before, after, q[m], q[(m + 1) % 4], tets);
        } else {
          cube[axis] = s == 0 ? 0 : s - 1;
          const int c = centre(cube);
          AddTet(c, q[0], q[1], q[2], tets);
          AddTet(c, q[0], q[2], q[3], tets);
        }
      }
    }
  }
}

}  // namespace

bool LatticeOptions::Validate(std::string* error) const {
  const LatticeOptions& options = *this;
  std::ostringstream out;
  if (options.nx < 1 || options.ny < 1 || options.nz < 1) {
    out << "the lattice's cube counts must be >= 1 (are " << options.nx << ", " << options.ny
        << ", " << options.nz << ")";
  } else if (!(options.spacing > 0.0) || !std::isfinite(options.spacing)) {
    out << "the lattice's spacing must be finite and > 0 (is " << options.spacing << ")";
  } else if (!std::isnormal(options.spacing * options.spacing * options.spacing)) {
    // An element's volume scales as spacing^3: beyond the doubles' range it is 0 or inf,
    // and every element is flat (the rest shape's CHECK).
    out << "the lattice's spacing " << options.spacing
        << " is beyond what doubles can hold of an element's volume (spacing^3 is "
        << options.spacing * options.spacing * options.spacing << ")";
  } else if (!options.origin.allFinite()) {
    out << "the lattice's origin must be finite";
  } else if (static_cast<double>(options.nx) * options.ny * options.nz * 48 >
             static_cast<double>(std::numeric_limits<int>::max())) {
    out << "a lattice of " << options.nx << " x " << options.ny << " x " << options.nz
        << " cubes is too large (at most " << std::numeric_limits<int>::max() / 48 << " cubes)";
  }
  *error = out.str();
  return error->empty();
}

TetMesh MakeLatticeMesh(const LatticeOptions& options) {
  std::string invalid;
  CHECK(options.Validate(&invalid)) << invalid;
  const long long cx = options.nx + 1LL, cy = options.ny + 1LL, cz = options.nz + 1LL;
  const long long num_cubes = static_cast<long long>(options.nx) * options.ny * options.nz;
  const long long num_corners_ll = cx * cy * cz;
  const bool bcc = options.type == LatticeType::kBcc;
  const long long num_vertices_ll = num_corners_ll + (bcc ? num_cubes : 0);
  // Every cube gives at most 12 elements (BCC: 6 faces x 4 / 2), 48 indices.
  CHECK_LE(num_cubes * 48, static_cast<long long>(std::numeric_limits<int>::max()))
      << "lattice too large";
  const int num_corners = static_cast<int>(num_corners_ll);

  TetMesh mesh;
  mesh.vertices.resize(3, static_cast<Eigen::Index>(num_vertices_ll));
  const double h = options.spacing;
  for (int k = 0; k < cz; ++k) {
    for (int j = 0; j < cy; ++j) {
      for (int i = 0; i < cx; ++i) {
        mesh.vertices.col(i + cx * (j + cy * k)) = options.origin + h * Eigen::Vector3d(i, j, k);
      }
    }
  }
  if (bcc) {
    for (int k = 0; k < options.nz; ++k) {
      for (int j = 0; j < options.ny; ++j) {
        for (int i = 0; i < options.nx; ++i) {
          mesh.vertices.col(num_corners + i + options.nx * (j + options.ny * k)) =
              options.origin + h * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        }
      }
    }
  }

  std::vector<int> tets;
  if (bcc) {
    tets.reserve(static_cast<size_t>(num_cubes) * 48);
    for (int axis = 0; axis < 3; ++axis) AddBccFaces(options, axis, num_corners, &tets);
  } else {
    tets.reserve(static_cast<size_t>(num_cubes) * 24);
    for (int k = 0; k < options.nz; ++k) {
      for (int j = 0; j < options.ny; ++j) {
        for (int i = 0; i < options.nx; ++i) AddKuhnCube(options, i, j, k, &tets);
      }
    }
  }
  const int num_tets = static_cast<int>(tets.size() / 4);
  mesh.tets = Eigen::Map<const Eigen::Matrix4Xi>(tets.data(), 4, num_tets);
  for (int t = 0; t < num_tets; ++t) {
    if (SignedTetVolume(mesh, mesh.vertices, t) < 0) std::swap(mesh.tets(1, t), mesh.tets(2, t));
  }
  return mesh;
}

}  // namespace aqs
