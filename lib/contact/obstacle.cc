#include "contact/obstacle.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <glog/logging.h>

#include "geometry/surface_components.h"
#include "mesh/mesh_io.h"
#include "util/line_reader.h"

namespace aqs {

namespace {

// +1 if the triangles face outward (positive enclosed volume), -1 if inward. Six times the
// enclosed signed volume, about the triangles' mean corner: for a closed surface the
// point does not matter, for one with a hole (which the inside test tolerates) a point
// that moves with the surface keeps the sign the same at every placement (about the
// origin, an open box turned inside out 2 units away from it).
double Orientation(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    for (int k = 0; k < 3; ++k) centre += vertices.col(triangles(k, t));
  }
  if (triangles.cols() > 0) centre /= 3.0 * static_cast<double>(triangles.cols());
  double volume = 0.0;
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    const Eigen::Vector3d a = vertices.col(triangles(0, t)) - centre;
    volume += a.dot((vertices.col(triangles(1, t)) - centre)
                        .cross(vertices.col(triangles(2, t)) - centre));
  }
  return volume < 0 ? -1.0 : 1.0;
}

}  // namespace

Obstacle::Obstacle(std::string name, const Eigen::Matrix3Xd& vertices,
                   const Eigen::Matrix3Xi& triangles)
    : name_(std::move(name)),
      vertices_(vertices),
      triangles_(triangles),
      winding_(vertices, triangles),
      orientation_(Orientation(vertices, triangles)),
      bvh_(vertices, triangles),
      features_(BuildSurfaceFeatures(triangles, static_cast<int>(vertices.cols()))) {
  if (vertices.cols() > 0) {
    lower_ = vertices.rowwise().minCoeff();
    upper_ = vertices.rowwise().maxCoeff();
  }
}

double Obstacle::SignedDistance(const Eigen::Vector3d& p, Eigen::Vector3d* gradient,
                                double max_distance) const {
  // Farther than max_distance from the bounding box: outside, and out of reach (no tree
  // search and no winding number: most of the points against most of a model's shells).
  if ((lower_ - p).cwiseMax(p - upper_).cwiseMax(0.0).norm() > max_distance) {
    gradient->setZero();
    return max_distance;
  }
  ClosestPointResult closest = bvh_.ClosestPoint(p, max_distance);
  const bool inside = orientation_ * winding_.WindingNumber(p) > 0.5;
  if (closest.triangle < 0) {
    if (!inside) {
      gradient->setZero();
      return max_distance;
    }
    // Deeper inside than max_distance: the whole depth (penetrations are never capped).
    closest = bvh_.ClosestPoint(p, std::numeric_limits<double>::infinity());
    CHECK_GE(closest.triangle, 0) << "an obstacle without triangles";
  }
  Eigen::Vector3d direction = p - closest.point;
  const double distance = direction.norm();
  if (distance > 1e-12) {
    direction /= distance;
  } else {  // on the surface: the triangle's outward normal, as p - closest would be
    const Eigen::Vector3d a = vertices_.col(triangles_(0, closest.triangle));
    direction = (inside ? -orientation_ : orientation_) *
                (vertices_.col(triangles_(1, closest.triangle)) - a)
                    .cross(vertices_.col(triangles_(2, closest.triangle)) - a)
                    .normalized();
  }
  *gradient = inside ? -direction : direction;
  return inside ? -distance : distance;
}

void Obstacle::FeaturesWithin(const Eigen::Vector3d& p, double reach,
                              std::vector<FeatureDistance>* features) const {
  // Scratch kept per thread (this runs for every contact point at every evaluation).
  thread_local std::vector<int> triangles, edges, corners;
  bvh_.TrianglesWithin(p, reach, &triangles);
  if (triangles.empty()) return;
  auto add = [&](const Eigen::Vector3d& closest, double weight, int dimension,
                 const Eigen::Vector3d& tangent) {
    FeatureDistance feature;
    feature.direction = p - closest;
    feature.distance = feature.direction.norm();
    if (!(feature.distance < reach)) return;
    feature.weight = weight;
    feature.closest_dimension = dimension;
    feature.tangent = tangent;
    if (feature.distance > 1e-12) {
      feature.direction /= feature.distance;
    } else {  // on the feature: no direction of its own (ObstaclePenalty gives the normal)
      feature.direction.setZero();
    }
    features->push_back(feature);
  };
  edges.clear();
  corners.clear();
  for (int t : triangles) {
    Eigen::Vector3d barycentric;
    const Eigen::Vector3d closest =
        ClosestPointOnTriangle(p, vertices_.col(triangles_(0, t)), vertices_.col(triangles_(1, t)),
                               vertices_.col(triangles_(2, t)), &barycentric);
    // The closest point's region: the corners of nonzero weight span it.
    int corners_used[3], count = 0;
    for (int k = 0; k < 3; ++k) {
      if (barycentric[k] != 0.0) corners_used[count++] = k;
    }
    Eigen::Vector3d tangent = Eigen::Vector3d::Zero();
    if (count == 2) {
      tangent = vertices_.col(triangles_(corners_used[1], t)) -
                vertices_.col(triangles_(corners_used[0], t));
      const double length = tangent.norm();
      if (length > 0.0) {
        tangent /= length;
      } else {
        count = 1;  // coincident corners: a point
      }
    }
    add(closest, 1.0, std::max(0, count - 1), tangent);
    for (int k = 0; k < 3; ++k) {
      edges.push_back(features_.triangle_edges(k, t));
      corners.push_back(triangles_(k, t));
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::sort(corners.begin(), corners.end());
  corners.erase(std::unique(corners.begin(), corners.end()), corners.end());
  for (int e : edges) {
    if (features_.edge_weights[e] == 0.0) continue;
    const Eigen::Vector3d a = vertices_.col(features_.edges(0, e));
    const Eigen::Vector3d b = vertices_.col(features_.edges(1, e));
    const double length2 = (b - a).squaredNorm();
    const double s = length2 > 0 ? std::clamp((p - a).dot(b - a) / length2, 0.0, 1.0) : 0.0;
    const bool inside = s > 0.0 && s < 1.0;
    add(a + s * (b - a), features_.edge_weights[e], inside ? 1 : 0,
        inside ? Eigen::Vector3d((b - a) / std::sqrt(length2)) : Eigen::Vector3d::Zero());
  }
  for (int v : corners) {
    if (features_.vertex_weights[v] != 0.0) {
      add(vertices_.col(v), features_.vertex_weights[v], 0, Eigen::Vector3d::Zero());
    }
  }
}

Eigen::Matrix3d FeatureDistanceHessian(const FeatureDistance& feature, double min_distance) {
  if (feature.closest_dimension >= 2 || !(feature.distance > 1e-12)) {
    return Eigen::Matrix3d::Zero();
  }
  Eigen::Matrix3d hessian =
      Eigen::Matrix3d::Identity() - feature.direction * feature.direction.transpose();
  if (feature.closest_dimension == 1) hessian -= feature.tangent * feature.tangent.transpose();
  return hessian / std::max(feature.distance, min_distance);
}

namespace {

// One comma-separated item of an obstacle spec: its text as given (for messages) and its
// whitespace-separated fields, double quotes removed.
struct SpecItem {
  std::string text;
  std::vector<std::string> fields;
};

// Splits `text` into items at commas and each item into fields at whitespace, both only
// outside double quotes ("My Teeth/teeth,upper.obj" is one field). A comma at the very end
// closes the last item without opening another, as it always did. False with *error if a
// quote is not closed.
bool SplitSpecItems(const std::string& text, std::vector<SpecItem>* items,
                    std::string* error) {
  SpecItem item;
  std::string field;
  bool in_field = false;  // a field has begun (an empty quoted field "" counts)
  bool quoted = false;
  auto end_field = [&]() {
    if (in_field) item.fields.push_back(field);
    field.clear();
    in_field = false;
  };
  for (const char c : text) {
    if (c == '"') {
      quoted = !quoted;
      in_field = true;
    } else if (quoted) {
      field += c;
    } else if (c == ',') {
      end_field();
      items->push_back(item);
      item = SpecItem();
      continue;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      end_field();
    } else {
      field += c;
      in_field = true;
    }
    item.text += c;
  }
  if (quoted) {
    *error = "obstacles '" + text + "': a double quote is not closed";
    return false;
  }
  end_field();
  if (!item.text.empty()) items->push_back(item);
  return true;
}

}  // namespace

bool ParseObstacleSpecs(const std::string& text, std::vector<ObstacleSpec>* specs,
                        std::string* error) {
  std::vector<SpecItem> items;
  if (!SplitSpecItems(text, &items, error)) return false;
  for (const SpecItem& spec_item : items) {
    const std::string& item = spec_item.text;
    const std::vector<std::string>& fields = spec_item.fields;
    if (fields.empty()) {
      *error = "obstacles '" + text + "': an empty item (between commas)";
      return false;
    }
    if (fields[0].empty()) {
      *error = "obstacle '" + item + "': the path is empty";
      return false;
    }
    ObstacleSpec spec;
    spec.path = fields[0];
    std::set<std::string> keys;
    for (size_t i = 1; i < fields.size(); ++i) {
      const size_t eq = fields[i].find('=');
      const std::string key = fields[i].substr(0, eq == std::string::npos ? 0 : eq);
      const std::string value = eq == std::string::npos ? "" : fields[i].substr(eq + 1);
      if (!key.empty() && !keys.insert(key).second) {
        *error = "obstacle '" + item + "': '" + key + "=' is given twice";
        return false;
      }
      if (key == "bone") {
        if (value.empty()) {
          *error = "obstacle '" + item + "': bone= needs the bone's name";
          return false;
        }
        spec.bone = value;
      } else if (key == "vertices") {
        const size_t colon = value.find(':');
        if (colon == std::string::npos || !ParseInt(value.substr(0, colon), &spec.first_vertex) ||
            !ParseInt(value.substr(colon + 1), &spec.end_vertex) || spec.first_vertex < 0 ||
            spec.end_vertex <= spec.first_vertex) {
          *error = "obstacle '" + item + "': vertices=a:b needs 0 <= a < b";
          return false;
        }
      } else if (eq == std::string::npos) {
        *error = "obstacle '" + item + "': '" + fields[i] +
                 "' after the path (a path with spaces or commas goes in double quotes)";
        return false;
      } else {
        *error = "obstacle '" + item + "': unknown field '" + fields[i] +
                 "' (expected: path [vertices=a:b] [bone=name])";
        return false;
      }
    }
    specs->push_back(spec);
  }
  return true;
}

bool ReadObstacleSurfaces(const std::vector<ObstacleSpec>& specs,
                          std::vector<Eigen::Matrix3Xd>* vertices,
                          std::vector<Eigen::Matrix3Xi>* triangles, std::string* error) {
  for (const ObstacleSpec& spec : specs) {
    SurfaceMesh surface;
    if (!ReadObj(spec.path, &surface, error)) return false;
    if (surface.num_triangles() == 0) {
      *error = spec.path + ": has no faces (an obstacle is a closed surface of triangles)";
      return false;
    }
    const int end = spec.end_vertex < 0 ? surface.num_vertices() : spec.end_vertex;
    if (end > surface.num_vertices()) {
      *error = spec.path + ": vertices=" + std::to_string(spec.first_vertex) + ":" +
               std::to_string(end) + " but the file has " + std::to_string(surface.num_vertices());
      return false;
    }
    std::vector<int> kept;
    for (int t = 0; t < surface.num_triangles(); ++t) {
      bool in = true;
      for (int k = 0; k < 3; ++k) {
        const int v = surface.triangles(k, t);
        in = in && v >= spec.first_vertex && v < end;
      }
      if (in) kept.push_back(t);
    }
    if (kept.empty()) {
      *error = spec.path + ": no triangle lies in the requested vertex range";
      return false;
    }
    // A triangle of no area has no normal: the signed distance to it, and the contact
    // solve that follows it, are undefined (a file of such triangles ran on for minutes).
    const double size = (surface.vertices.rowwise().maxCoeff() -
                         surface.vertices.rowwise().minCoeff()).norm();
    for (int t : kept) {
      const Eigen::Vector3d a = surface.vertices.col(surface.triangles(0, t));
      const Eigen::Vector3d b = surface.vertices.col(surface.triangles(1, t));
      const Eigen::Vector3d c = surface.vertices.col(surface.triangles(2, t));
      if (!((b - a).cross(c - a).norm() > 1e-12 * size * size)) {
        *error = spec.path + ": triangle " + std::to_string(t) + " (vertices " +
                 std::to_string(surface.triangles(0, t) + 1) + ", " +
                 std::to_string(surface.triangles(1, t) + 1) + ", " +
                 std::to_string(surface.triangles(2, t) + 1) +
                 ", 1-based) has no area: an obstacle's triangles need a normal";
        return false;
      }
    }
    Eigen::Matrix3Xi tris(3, kept.size());
    for (size_t i = 0; i < kept.size(); ++i) tris.col(i) = surface.triangles.col(kept[i]);
    vertices->push_back(surface.vertices);
    triangles->push_back(tris);
  }
  return true;
}

std::vector<MovingObstacle> SplitIntoShells(const MovingObstacle& obstacle) {
  const SurfaceComponents components =
      FindSurfaceComponents(static_cast<int>(obstacle.vertices.cols()), obstacle.triangles);
  if (components.num_components() <= 1) return {obstacle};
  std::vector<MovingObstacle> shells(components.num_components());
  std::vector<int> local(obstacle.vertices.cols(), -1);
  for (int c = 0; c < components.num_components(); ++c) {
    MovingObstacle& shell = shells[c];
    shell.name = obstacle.name + " shell " + std::to_string(c + 1);
    shell.bone = obstacle.bone;
    const std::vector<int>& vertices = components.vertices[c];
    shell.vertices.resize(3, vertices.size());
    for (size_t k = 0; k < vertices.size(); ++k) {
      shell.vertices.col(k) = obstacle.vertices.col(vertices[k]);
      local[vertices[k]] = static_cast<int>(k);
    }
  }
  std::vector<int> count(components.num_components(), 0);
  for (int component : components.triangle_component) ++count[component];
  for (int c = 0; c < components.num_components(); ++c) shells[c].triangles.resize(3, count[c]);
  std::fill(count.begin(), count.end(), 0);
  for (Eigen::Index t = 0; t < obstacle.triangles.cols(); ++t) {
    const int c = components.triangle_component[t];
    for (int k = 0; k < 3; ++k) shells[c].triangles(k, count[c]) = local[obstacle.triangles(k, t)];
    ++count[c];
  }
  return shells;
}

std::unique_ptr<Obstacle> MovingObstacle::Place(const std::vector<RigidTransform>& bones) const {
  if (bone < 0) return std::make_unique<Obstacle>(name, vertices, triangles);
  CHECK_LT(bone, static_cast<int>(bones.size())) << "obstacle " << name << ": bone " << bone;
  return std::make_unique<Obstacle>(name, bones[bone].Apply(vertices), triangles);
}

}  // namespace aqs
