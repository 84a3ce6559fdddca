#include "geometry/plane_cuts.h"

#include <cmath>

#include <glog/logging.h>

#include <Eigen/Geometry>

#include "util/line_reader.h"
#include "util/text_split.h"

namespace aqs {
namespace {

double Level(const PlaneCut& cut, const Eigen::Vector3d& p) {
  return cut.normal.dot(p) + cut.quadratic.dot(p.cwiseProduct(p)) - cut.offset;
}

int Side(const PlaneCut& cut, const Eigen::Vector3d& p) { return Level(cut, p) >= 0 ? 1 : -1; }

}  // namespace

CutMesh ApplyPlaneCuts(const TetMesh& mesh, const std::vector<PlaneCut>& cuts) {
  CutMesh out;
  out.mesh = mesh;
  out.original_vertex.resize(mesh.num_vertices());
  for (int v = 0; v < mesh.num_vertices(); ++v) out.original_vertex[v] = v;
  for (size_t c = 0; c < cuts.size(); ++c) {
    const PlaneCut& cut = cuts[c];
    TetMesh& m = out.mesh;
    const int num_vertices = m.num_vertices();
    const int num_elements = m.num_tets();
    std::vector<int> side(num_vertices);
    for (int v = 0; v < num_vertices; ++v) side[v] = Side(cut, m.vertices.col(v));
    // ghost[v]: v's copy for the other side (created on first use).
    std::vector<int> ghost(num_vertices, -1);
    std::vector<Eigen::Vector3d> new_vertices;
    std::vector<Eigen::Vector4i> new_elements;
    std::vector<int> element_side(num_elements, 0), element_twin(num_elements, -1);
    auto ghost_of = [&](int v) {
      if (ghost[v] < 0) {
        ghost[v] = num_vertices + static_cast<int>(new_vertices.size());
        new_vertices.push_back(m.vertices.col(v));
        out.original_vertex.push_back(out.original_vertex[v]);
      }
      return ghost[v];
    };
    for (int e = 0; e < num_elements; ++e) {
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
      int plus = 0;
      for (int k = 0; k < 4; ++k) {
        centroid += 0.25 * m.vertices.col(m.tets(k, e));
        plus += side[m.tets(k, e)] > 0;
      }
      if (plus == 0 || plus == 4 || !cut.region.contains(centroid)) continue;
      Eigen::Vector4i copy_plus, copy_minus;
      for (int k = 0; k < 4; ++k) {
        const int v = m.tets(k, e);
        copy_plus[k] = side[v] > 0 ? v : ghost_of(v);
        copy_minus[k] = side[v] < 0 ? v : ghost_of(v);
      }
      m.tets.col(e) = copy_plus;
      element_side[e] = 1;
      element_twin[e] = num_elements + static_cast<int>(new_elements.size());
      new_elements.push_back(copy_minus);
    }
    // Append ghosts and the - copies.
    m.vertices.conservativeResize(3, num_vertices + new_vertices.size());
    for (size_t i = 0; i < new_vertices.size(); ++i) m.vertices.col(num_vertices + i) = new_vertices[i];
    m.tets.conservativeResize(4, num_elements + new_elements.size());
    for (size_t i = 0; i < new_elements.size(); ++i) {
      m.tets.col(num_elements + i) = new_elements[i];
      element_side.push_back(-1);
      element_twin.push_back(-1);
    }
    for (int e = 0; e < num_elements; ++e) {
      if (element_twin[e] >= 0) element_twin[element_twin[e]] = e;
    }
    // Earlier cuts' labels: a copy inherits its original's side, and its twin is the
    // same-side copy (for this cut) of its original's twin. The twin has the same
    // geometry, so this cut splits it too, and the four copies of an element cut twice
    // pair up: + with + and - with - for this cut, across the earlier one.
    for (size_t prev = 0; prev < c; ++prev) {
      std::vector<int>& s = out.element_side[prev];
      std::vector<int>& t = out.element_twin[prev];
      s.resize(m.num_tets(), 0);
      t.resize(m.num_tets(), -1);
      for (int e = 0; e < num_elements; ++e) {
        const int copy = element_twin[e];
        if (element_side[e] == 1 && copy >= 0) {
          s[copy] = s[e];
          t[copy] = t[e] >= 0 ? element_twin[t[e]] : -1;
        }
      }
    }
    out.element_side.push_back(element_side);
    out.element_twin.push_back(element_twin);
  }
  return out;
}

int AssignEmbeddingSides(const CutMesh& cut_mesh, const std::vector<PlaneCut>& cuts,
                         const Eigen::Matrix3Xd& points, const Eigen::Matrix3Xd& normals,
                         double margin, Embedding* embedding) {
  CHECK_EQ(cut_mesh.element_side.size(), cuts.size());
  CHECK(normals.cols() == 0 || normals.cols() == points.cols());
  int moved = 0;
  for (size_t c = 0; c < cuts.size(); ++c) {
    for (int i = 0; i < embedding->num_points(); ++i) {
      const int e = embedding->element[i];
      const int element_side = cut_mesh.element_side[c][e];
      const int twin = cut_mesh.element_twin[c][e];
      if (element_side == 0 || twin < 0) continue;
      const Eigen::Vector3d p = points.col(i);
      int side = Side(cuts[c], p);
      if (normals.cols() > 0) {
        const Eigen::Vector3d gradient = cuts[c].normal + 2.0 * cuts[c].quadratic.cwiseProduct(p);
        const double along = normals.col(i).dot(gradient);
        if (std::abs(Level(cuts[c], p)) < margin * gradient.norm() && along != 0.0) {
          side = along < 0 ? 1 : -1;
        }
      }
      if (side != element_side) {
        embedding->element[i] = twin;
        ++moved;
      }
    }
  }
  return moved;
}

bool ParsePlaneCut(const std::string& text, PlaneCut* cut, std::string* error) {
  const size_t at = text.find('@');
  auto parse = [&](const std::string& part, std::vector<double>* values) {
    for (const std::string& item : SplitFields(part)) {
      double v = 0;
      if (!ParseDouble(item, &v)) {
        *error = "cut '" + text + "': '" + item + "' is not a number";
        return false;
      }
      values->push_back(v);
    }
    return true;
  };
  std::vector<double> surface, box;
  const char* kExpected =
      "expected nx,ny,nz,offset[,qx,qy,qz]@xmin,ymin,zmin,xmax,ymax,zmax";
  if (at == std::string::npos) {
    *error = "cut '" + text + "': " + kExpected;
    return false;
  }
  if (!parse(text.substr(0, at), &surface) || !parse(text.substr(at + 1), &box)) return false;
  if ((surface.size() != 4 && surface.size() != 7) || box.size() != 6) {
    *error = "cut '" + text + "': " + kExpected;
    return false;
  }
  std::vector<double> values(surface.begin(), surface.begin() + 4);
  values.insert(values.end(), box.begin(), box.end());
  const Eigen::Vector3d quadratic =
      surface.size() == 7 ? Eigen::Vector3d(surface[4], surface[5], surface[6])
                          : Eigen::Vector3d::Zero();
  const Eigen::Vector3d normal(values[0], values[1], values[2]);
  if (!(normal.norm() > 0)) {
    *error = "cut '" + text + "': the normal must not be zero";
    return false;
  }
  cut->normal = normal.normalized();
  cut->quadratic = quadratic / normal.norm();
  cut->offset = values[3] / normal.norm();
  const Eigen::Vector3d lo(values[4], values[5], values[6]), hi(values[7], values[8], values[9]);
  if (!(lo.array() < hi.array()).all()) {
    *error = "cut '" + text + "': each region minimum must be below its maximum";
    return false;
  }
  cut->region = Eigen::AlignedBox3d(lo, hi);
  return true;
}

}  // namespace aqs
