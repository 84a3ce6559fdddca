#include "prepare/boundary_rules.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include <glog/logging.h>

#include "geometry/points_near_model.h"
#include "geometry/rigid_transform.h"
#include "geometry/triangle_bvh.h"
#include "geometry/winding_number.h"
#include "io/vertex_list_io.h"
#include "mesh/mesh_io.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/name_rules.h"
#include "util/number_format.h"
#include "util/option_checks.h"
#include "util/text_split.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

std::string Replace(std::string text, const std::string& key, const std::string& value) {
  // Searched on after the inserted value, which may hold the key itself (a pose named
  // "wide{pose}": searched from the start, the replacement never ended).
  for (size_t pos = 0; (pos = text.find(key, pos)) != std::string::npos; pos += value.size()) {
    text.replace(pos, key.size(), value);
  }
  return text;
}

// Per-pose transforms of a bone, fitted to its moving vertices.
bool FitBone(const BoneRule& rule, const std::vector<std::string>& pose_names, Bone* bone,
             std::ostringstream* log, std::string* error) {
  SurfaceMesh rest;
  if (!ReadObj(rule.neutral_mesh, &rest, error)) return false;
  const int n = rest.num_vertices();
  if (n == 0) {
    *error = rule.neutral_mesh + ": the bone '" + rule.name + "' at rest has no vertices";
    return false;
  }
  std::vector<Eigen::Matrix3Xd> posed(pose_names.size());
  Eigen::VectorXd largest = Eigen::VectorXd::Zero(n);
  int with_files = 0;
  for (size_t p = 0; p < pose_names.size(); ++p) {
    const std::string path = Replace(rule.pose_mesh_pattern, "{pose}", pose_names[p]);
    if (rule.pose_mesh_pattern.empty() || !MayExist(path)) continue;
    SurfaceMesh surface;
    if (!ReadObj(path, &surface, error)) return false;
    if (surface.num_vertices() != n) {
      *error = path + ": " + std::to_string(surface.num_vertices()) + " vertices, but the bone '" +
               rule.name + "' at rest (" + rule.neutral_mesh + ") has " + std::to_string(n);
      return false;
    }
    // One vertex far away (in another unit or frame) made every other vertex's motion
    // look like none, and the bone static in every pose.
    if (!CheckPointsNearModel(path, rest.vertices, surface.vertices, error)) return false;
    posed[p] = surface.vertices;
    largest = largest.cwiseMax((surface.vertices - rest.vertices).colwise().norm().transpose());
    ++with_files;
  }
  if (!rule.pose_mesh_pattern.empty() && with_files == 0 && !pose_names.empty()) {
    *error = "bone '" + rule.name + "': its pose surfaces (the pattern '" +
             rule.pose_mesh_pattern + "') exist for none of the " +
             std::to_string(pose_names.size()) + " poses (the first would be '" +
             Replace(rule.pose_mesh_pattern, "{pose}", pose_names[0]) +
             "'); '{pose}' in the pattern stands for each pose's name";
    return false;
  }
  bone->name = rule.name;
  bone->pose_transforms.assign(pose_names.size(), RigidTransform());
  const double threshold = rule.moving_fraction * largest.maxCoeff();
  std::vector<int> moving;
  for (int i = 0; i < n; ++i) {
    if (largest[i] > threshold && largest[i] > 0) moving.push_back(i);
  }
  *log << "bone '" << rule.name << "': " << n << " vertices, pose surfaces for " << with_files
       << " of " << pose_names.size() << " poses, transform fitted to " << moving.size()
       << " moving vertices\n";
  if (moving.empty()) return true;  // the bone never moves: identities
  if (moving.size() < 3) {
    *error = "bone '" + rule.name + "': only " + std::to_string(moving.size()) +
             " of its vertices move (by more than " + FormatDouble(rule.moving_fraction) +
             " of the largest motion): a rigid transform needs 3; are the pose surfaces "
             "the bone's, in its vertex order?";
    return false;
  }
  Eigen::Matrix3Xd from(3, moving.size()), to(3, moving.size());
  for (size_t i = 0; i < moving.size(); ++i) from.col(i) = rest.vertices.col(moving[i]);
  for (size_t p = 0; p < pose_names.size(); ++p) {
    if (posed[p].cols() == 0) continue;
    for (size_t i = 0; i < moving.size(); ++i) to.col(i) = posed[p].col(moving[i]);
    double rms = 0;
    bone->pose_transforms[p] = FitRigidTransform(from, to, &rms);
    const Eigen::AngleAxisd angle(bone->pose_transforms[p].rotation);
    *log << "  pose " << pose_names[p] << ": rotation " << angle.angle() * 180.0 / M_PI
         << " deg, translation " << bone->pose_transforms[p].translation.norm()
         << ", fit rms " << rms << "\n";
  }
  return true;
}

// Vertices of `points` inside the closed surface in `path`.
bool InsideMesh(const std::string& path, const Eigen::Matrix3Xd& points, int threads,
                std::vector<bool>* inside, std::string* error) {
  SurfaceMesh surface;
  if (!ReadObj(path, &surface, error)) return false;
  if (surface.num_triangles() == 0) {
    *error = path + ": has no faces (a closed surface is needed for an inside test)";
    return false;
  }
  const FastWindingNumber winding(surface.vertices, surface.triangles);
  const Eigen::VectorXd w = winding.WindingNumbers(points, threads);
  inside->assign(points.cols(), false);
  // |w|: a surface whose triangles all face inward (as exporters may write it) has
  // winding number -1 inside.
  for (Eigen::Index i = 0; i < points.cols(); ++i) (*inside)[i] = std::abs(w[i]) > 0.5;
  return true;
}

// Marks the fixed vertices driven by no bone (owner -1) that lie within `clearance` of a
// vertex some bone drives (owner >= 0). All false for clearance 0 or without bones.
std::vector<bool> VerticesNearBones(const TetMesh& mesh, const std::vector<bool>& fixed,
                                    const std::vector<int>& owner, double clearance) {
  const int nv = mesh.num_vertices();
  std::vector<bool> near(nv, false);
  if (!(clearance > 0.0)) return near;
  std::vector<int> driven;
  for (int v = 0; v < nv; ++v) {
    if (owner[v] >= 0) driven.push_back(v);
  }
  if (driven.empty()) return near;
  Eigen::Matrix3Xd points(3, driven.size());
  for (size_t k = 0; k < driven.size(); ++k) points.col(k) = mesh.vertices.col(driven[k]);
  const double squared = clearance * clearance;
  for (int v = 0; v < nv; ++v) {
    if (!fixed[v] || owner[v] >= 0) continue;
    near[v] = (points.colwise() - mesh.vertices.col(v)).colwise().squaredNorm().minCoeff() <=
              squared;
  }
  return near;
}

}  // namespace

bool ParseBox(const std::string& text, Eigen::AlignedBox3d* box, std::string* error) {
  std::vector<double> values;
  for (const std::string& item : SplitFields(text)) {
    double v = 0;
    if (!ParseDouble(item, &v)) {
      *error = "box '" + text + "': '" + item + "' is not a number";
      return false;
    }
    values.push_back(v);
  }
  if (values.size() != 6) {
    *error = "box '" + text + "': expected six numbers xmin,ymin,zmin,xmax,ymax,zmax";
    return false;
  }
  const Eigen::Vector3d lo(values[0], values[1], values[2]), hi(values[3], values[4], values[5]);
  if (!(lo.array() < hi.array()).all()) {
    *error = "box '" + text + "': each minimum must be below its maximum";
    return false;
  }
  *box = Eigen::AlignedBox3d(lo, hi);
  return true;
}

bool BoundaryRuleOptions::Validate(std::string* error) const {
  OptionChecks checks;
  checks.Require(!std::isnan(fixed_depth) && std::isfinite(fixed_depth),
                 "fixed_depth must be finite (> 0 to use) (is " + OptionValue(fixed_depth) + ")");
  for (const BoneRule& bone : bones) {
    checks.Require(NameProblem(bone.name).empty(),
                   "bones.name '" + bone.name + "' " + NameProblem(bone.name))
        .InRange("bones.moving_fraction", bone.moving_fraction, 0.0, 1.0)
        .Require(!bone.region_boxes.empty(), "bones.region_boxes must not be empty")
        .Require(bone.pose_mesh_pattern.empty() ||
                     bone.pose_mesh_pattern.find("{pose}") != std::string::npos,
                 "bones.pose_mesh_pattern must contain '{pose}' (where each pose's name goes; "
                 "is '" + bone.pose_mesh_pattern + "')");
  }
  checks.Require(bone_clearance >= 0.0 && std::isfinite(bone_clearance),
                 "bone_clearance must be finite and >= 0 (is " + OptionValue(bone_clearance) + ")");
  return checks.IntInRange("num_threads", num_threads, 1, 1024).Done(error);
}

bool ApplyBoundaryRules(const BoundaryRuleOptions& options, const TetMesh& mesh,
                        const SurfaceMesh& surface, const std::vector<std::string>& pose_names,
                        const ListNumbering* list_numbering, ActiveModel* model,
                        std::string* log_out, std::string* error) {
  std::ostringstream log;
  const int nv = mesh.num_vertices();
  std::vector<bool> fixed(nv, false);
  auto count = [](const std::vector<bool>& flags) {
    int c = 0;
    for (bool f : flags) c += f;
    return c;
  };
  if (options.fixed_depth > 0) {
    const FastWindingNumber winding(surface.vertices, surface.triangles);
    const Eigen::VectorXd w = winding.WindingNumbers(mesh.vertices, options.num_threads);
    const TriangleBvh bvh(surface.vertices, surface.triangles);
    const std::vector<ClosestPointResult> closest =
        bvh.ClosestPoints(mesh.vertices, options.num_threads);
    int selected = 0;
    for (int v = 0; v < nv; ++v) {
      // |w|: exporters may write a surface's triangles inward (as InsideMesh allows).
      if (std::abs(w[v]) > 0.5 && closest[v].distance > options.fixed_depth) {
        fixed[v] = true;
        ++selected;
      }
    }
    log << "fixed by depth > " << options.fixed_depth << ": " << selected << " vertices\n";
  }
  for (const Eigen::AlignedBox3d& box : options.fixed_boxes) {
    int selected = 0;
    for (int v = 0; v < nv; ++v) {
      if (box.contains(mesh.vertices.col(v))) {
        fixed[v] = true;
        ++selected;
      }
    }
    log << "fixed by box: " << selected << " vertices\n";
  }
  for (const std::string& path : options.fixed_inside_meshes) {
    std::vector<bool> inside;
    if (!InsideMesh(path, mesh.vertices, options.num_threads, &inside, error)) return false;
    if (count(inside) == 0) {
      *error = path + ": no simulation vertex lies inside it (--fixed_inside): is it in the "
                      "model's frame and units, and closed?";
      return false;
    }
    for (int v = 0; v < nv; ++v) fixed[v] = fixed[v] || inside[v];
    log << "fixed inside " << path << ": " << count(inside) << " vertices\n";
  }
  if (!options.fixed_list.empty()) {
    CHECK(list_numbering == nullptr || static_cast<int>(list_numbering->origin.size()) == nv);
    const int list_size = list_numbering == nullptr ? nv : list_numbering->num_vertices;
    std::vector<int> list;
    if (!ReadVertexList(options.fixed_list, list_size, &list, error)) return false;
    if (list.empty()) {
      *error = options.fixed_list + ": lists no vertices";
      return false;
    }
    std::vector<char> listed(list_size, 0);
    for (int v : list) listed[v] = 1;
    std::vector<char> found(list_size, 0);
    int selected = 0;
    for (int v = 0; v < nv; ++v) {
      const int origin = list_numbering == nullptr ? v : list_numbering->origin[v];
      if (!listed[origin]) continue;
      fixed[v] = true;
      found[origin] = 1;
      ++selected;
    }
    for (int v : list) {
      if (!found[v]) {
        *error = options.fixed_list + ": vertex " + std::to_string(v) +
                 " is not in the simulation mesh (used by no element of --tet_mesh, "
                 "removed as held by fewer than --min_vertex_elements elements, or outside "
                 "every --keep_box)";
        return false;
      }
    }
    log << "fixed by list " << options.fixed_list << ": " << list.size() << " vertices";
    if (selected != static_cast<int>(list.size())) {
      log << " (" << selected << " with their cut copies)";
    }
    log << "\n";
  }
  if (count(fixed) == 0) {
    *error = "no simulation vertex is fixed: give --fixed_depth, --fixed_box, --fixed_inside or "
             "--fixed_list (a body without fixed vertices has no unique equilibrium)";
    return false;
  }
  model->static_vertices.clear();
  model->bones.clear();
  std::vector<int> owner(nv, -1);
  for (size_t b = 0; b < options.bones.size(); ++b) {
    Bone bone;
    if (!FitBone(options.bones[b], pose_names, &bone, &log, error)) return false;
    for (int v = 0; v < nv; ++v) {
      if (!fixed[v] || owner[v] >= 0) continue;
      for (const Eigen::AlignedBox3d& box : options.bones[b].region_boxes) {
        if (box.contains(mesh.vertices.col(v))) {
          owner[v] = static_cast<int>(b);
          bone.vertices.push_back(v);
          break;
        }
      }
    }
    log << "bone '" << bone.name << "' drives " << bone.vertices.size() << " fixed vertices\n";
    if (bone.vertices.empty()) {
      *error = "bone '" + bone.name + "': no fixed vertex lies in its region (--bone_region), "
               "so it would drive nothing";
      return false;
    }
    model->bones.push_back(bone);
  }
  const std::vector<bool> cleared = VerticesNearBones(mesh, fixed, owner, options.bone_clearance);
  if (options.bone_clearance > 0.0) {
    log << "left free within " << options.bone_clearance << " of a bone-driven vertex: "
        << count(cleared) << " vertices\n";
  }
  for (int v = 0; v < nv; ++v) {
    if (fixed[v] && owner[v] < 0 && !cleared[v]) model->static_vertices.push_back(v);
  }
  log << "fixed vertices: " << model->static_vertices.size() << " static";
  size_t held = model->static_vertices.size();
  for (const Bone& bone : model->bones) {
    log << ", " << bone.vertices.size() << " on " << bone.name;
    held += bone.vertices.size();
  }
  log << " (of " << nv << ")\n";
  // (Bone-driven vertices are as fixed as static ones; --bone_clearance frees some.)
  if (held == static_cast<size_t>(nv)) {
    *error = "every simulation vertex (" + std::to_string(nv) + ") is fixed, at rest or driven "
             "by a bone: nothing can move (check --fixed_depth, --fixed_box, --fixed_inside, "
             "--fixed_list, --bone_region and --bone_clearance)";
    return false;
  }
  *log_out += log.str();
  return true;
}

}  // namespace aqs
