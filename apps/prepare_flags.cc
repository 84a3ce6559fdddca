#include "prepare_flags.h"

#include <gflags/gflags.h>

#include "app_common.h"
#include "prepare/pose_files.h"
#include "prepare/volumetric_targets.h"

DEFINE_string(neutral, "", "Neutral surface (OBJ).");
DEFINE_string(poses, "", "Pose surfaces with the neutral's vertex order: a folder (all *.obj), "
              "a glob ('dir/*.obj'), a .txt list (one path per line) or a comma-separated list.");
DEFINE_string(pose_exclude, "", "Glob on file names to leave out of --poses (e.g. *.teeth.obj).");
DEFINE_string(tet_mesh, "", "A tet mesh to simulate instead of a lattice (.mesh, .node/.ele, "
              ".msh), in the neutral's unit and frame (a box 4x larger or smaller, or one "
              "that misses the neutral's centre, is refused).");
DEFINE_double(spacing, 0.0, "Lattice cube edge for the simulation mesh (model units); required "
              "without --tet_mesh.");
DEFINE_string(lattice, "bcc", "Lattice type: bcc or kuhn.");
DEFINE_double(shell, 0.0, "Keep only elements within this distance of the surface (0: all inside).");
DEFINE_int32(min_vertex_elements, 4, "After meshing and --keep_box, remove the elements at "
             "vertices that fewer elements hold, repeatedly (0 or 1: none; at most 24). "
             "Vertices held by one or two elements make equilibria unstable.");
DEFINE_string(keep_box, "", "Keep only elements whose centroid is in one of these boxes: "
              "'xmin,ymin,zmin,xmax,ymax,zmax', several separated by ';'.");
DEFINE_string(cut, "", "Planar cuts where surface parts touch and must part (lips, eyelids): "
              "'nx,ny,nz,offset@xmin,ymin,zmin,xmax,ymax,zmax' (the plane n.x = offset, "
              "within the box), several separated by ';'.");
DEFINE_double(cut_margin, 0.0, "Within this distance of a cut, surface vertices take the side "
              "their normal faces away from (the material side of a slit).");
DEFINE_double(mu, 1.0, "Stiffness of every element.");
DEFINE_double(fixed_depth, -1.0, "Fix the vertices deeper than this under the surface.");
DEFINE_string(fixed_box, "", "Fix the vertices in these boxes (';'-separated).");
DEFINE_string(fixed_inside, "", "Fix the vertices inside these closed surfaces (comma-separated "
              "OBJ; triangles facing out or in). One that holds no vertex is refused.");
DEFINE_string(fixed_list, "",
              "Fix the vertices listed in this file (one index per line): indices of "
              "--tet_mesh's vertices as in its file (prepare renumbers them when it crops, "
              "prunes and cuts; a cut copy of a listed vertex is fixed too, a listed vertex "
              "removed is an error), else of the simulation mesh prepare makes "
              "(model/mesh.mesh).");
DEFINE_string(bone_name, "jaw", "Name of the bone (with --bone_mesh).");
DEFINE_string(bone_mesh, "", "A rigid bone surface at rest (OBJ) whose per-pose motion drives "
              "the fixed vertices in --bone_region.");
DEFINE_string(bone_poses, "", "The bone's per-pose surfaces: a path pattern with {pose} for the "
              "pose name (poses without a file keep the bone at rest).");
DEFINE_string(bone_region, "", "Boxes (';'-separated) whose fixed vertices the bone drives.");
DEFINE_double(bone_moving_fraction, 0.1, "Fit the bone's motion to its vertices that move more "
              "than this fraction of the largest motion.");
DEFINE_double(bone_clearance, 0.0, "Leave free the static fixed vertices within this distance "
              "of a vertex the bone drives, so that the tissue between them can deform (0: none).");
DEFINE_double(attachment_stiffness, 100.0, "Springs pulling the embedded surface to each pose, "
              "per unit area, relative to one layer of elements.");
DEFINE_string(inverted_targets, "exact", "The volumetric target of an element a pose's embedded "
              "simulation inverts: exact (a symmetric target with a negative eigenvalue, which "
              "reproduces the inverted element) or mirror (sqrt(F^T F), its mirror image, as "
              "models prepared before 2026-12-06 had).");
DEFINE_bool(overwrite, false, "Replace whatever is at --model. Without it, only a missing path, "
            "an empty directory or an ActiveQS model is replaced; anything else is refused "
            "(exit 1) before any work.");
DEFINE_string(mirror_poses, "", "Also train on the mirror image of every pose that is not "
              "symmetric (named mirror_NAME; its bones' motions mirrored): the axis normal to the "
              "mirror plane, x, y or z (empty: none). The neutral must be mirror-symmetric.");
DEFINE_double(mirror_plane, 0.0, "The mirror plane of --mirror_poses: axis = this (needs "
              "--mirror_poses).");
DEFINE_double(mirror_tolerance, 1e-3, "The neutral's largest asymmetry --mirror_poses accepts, "
              "as a fraction of its bounding-box diagonal (needs --mirror_poses).");
DEFINE_bool(halfway_poses, false, "Also train on the pose halfway to every pose whose bones "
            "move (named half_NAME): the surface halfway between the neutral and the pose, each "
            "bone halfway along its screw motion (a model trained on a jaw opened all the way "
            "has no example of the way there; docs/results.md).");
DEFINE_double(halfway_min_bone_motion, 0.01, "--halfway_poses: the poses whose bones move "
              "a vertex farther than this fraction of the simulation mesh's bounding-box "
              "diagonal get a halfway pose; in (0, 1] (needs --halfway_poses).");
DEFINE_double(prepare_tolerance, 1e-6, "Relative force tolerance of the embedded simulations.");
DECLARE_int32(threads);
DECLARE_string(model);
DECLARE_string(pose_dir);

namespace aqs {
namespace {

bool ParseBoxes(const std::string& text, std::vector<Eigen::AlignedBox3d>* boxes,
                std::string* error) {
  for (const std::string& item : SplitList(text, ';')) {
    Eigen::AlignedBox3d box;
    if (!ParseBox(item, &box, error)) return false;
    boxes->push_back(box);
  }
  return true;
}

}  // namespace

bool PrepareOptionsFromFlags(PrepareJobOptions* options, std::string* error) {
  if (FLAGS_neutral.empty() || FLAGS_poses.empty() || FLAGS_model.empty()) {
    *error = "--neutral, --poses and --model are required";
    return false;
  }
  options->neutral = FLAGS_neutral;
  if (!ResolvePosePaths(FLAGS_poses, FLAGS_pose_exclude, &options->pose_paths, error,
                        FLAGS_pose_dir)) {
    return false;
  }
  options->output = FLAGS_model;
  options->overwrite = FLAGS_overwrite;
  options->tet_mesh = FLAGS_tet_mesh;
  if (FLAGS_tet_mesh.empty() && FLAGS_spacing == 0.0) {
    *error = "--spacing (the lattice cube edge, > 0) is required without --tet_mesh";
    return false;
  }
  if (!FLAGS_tet_mesh.empty() && FLAGS_spacing != 0.0) {
    *error = "give --spacing (a lattice is made) or --tet_mesh (that mesh is used), not both";
    return false;
  }
  options->meshing.spacing = FLAGS_spacing;
  if (FLAGS_lattice == "bcc") {
    options->meshing.type = LatticeType::kBcc;
  } else if (FLAGS_lattice == "kuhn") {
    options->meshing.type = LatticeType::kKuhn;
  } else {
    *error = "--lattice must be bcc or kuhn, got '" + FLAGS_lattice + "'";
    return false;
  }
  options->meshing.shell_thickness = FLAGS_shell;
  options->min_elements_per_vertex = FLAGS_min_vertex_elements;
  options->meshing.num_threads = FLAGS_threads;
  if (!ParseBoxes(FLAGS_keep_box, &options->keep_boxes, error)) {
    *error = "--keep_box: " + *error;
    return false;
  }
  {
    for (const std::string& item : SplitList(FLAGS_cut, ';')) {
      PlaneCut cut;
      if (!ParsePlaneCut(item, &cut, error)) {
        *error = "--cut: " + *error;
        return false;
      }
      options->cuts.push_back(cut);
    }
  }
  options->cut_margin = FLAGS_cut_margin;
  options->mu = FLAGS_mu;
  options->boundary.fixed_depth = FLAGS_fixed_depth;
  options->boundary.bone_clearance = FLAGS_bone_clearance;
  if (!ParseBoxes(FLAGS_fixed_box, &options->boundary.fixed_boxes, error)) {
    *error = "--fixed_box: " + *error;
    return false;
  }
  options->boundary.fixed_inside_meshes = SplitList(FLAGS_fixed_inside);
  options->boundary.fixed_list = FLAGS_fixed_list;
  if (!FLAGS_bone_mesh.empty()) {
    BoneRule bone;
    bone.name = FLAGS_bone_name;
    bone.neutral_mesh = FLAGS_bone_mesh;
    bone.pose_mesh_pattern = FLAGS_bone_poses;
    bone.moving_fraction = FLAGS_bone_moving_fraction;
    if (!ParseBoxes(FLAGS_bone_region, &bone.region_boxes, error)) {
      *error = "--bone_region: " + *error;
      return false;
    }
    if (bone.region_boxes.empty()) {
      *error = "--bone_mesh needs --bone_region (the boxes of fixed vertices it drives)";
      return false;
    }
    if (bone.pose_mesh_pattern.empty()) {
      *error = "--bone_mesh needs --bone_poses (the bone's pose surfaces, with {pose} for the "
               "pose name)";
      return false;
    }
    options->boundary.bones.push_back(bone);
  } else if (!FLAGS_bone_region.empty() || !FLAGS_bone_poses.empty()) {
    *error = "--bone_region and --bone_poses describe a bone: they need --bone_mesh";
    return false;
  }
  if (!FLAGS_mirror_poses.empty()) {
    const std::string axes = "xyz";
    const size_t axis = axes.find(FLAGS_mirror_poses);
    if (FLAGS_mirror_poses.size() != 1 || axis == std::string::npos) {
      *error = "--mirror_poses must be x, y or z (the axis normal to the mirror plane; is '" +
               FLAGS_mirror_poses + "')";
      return false;
    }
    options->mirror.axis = static_cast<int>(axis);
  }
  // Flags that describe a stage left off would be dropped without a word.
  const auto given = [](const char* flag) {
    return !gflags::GetCommandLineFlagInfoOrDie(flag).is_default;
  };
  const bool plane = given("mirror_plane"), tolerance = given("mirror_tolerance");
  if (FLAGS_mirror_poses.empty() && (plane || tolerance)) {
    *error = plane && tolerance
                 ? "--mirror_plane and --mirror_tolerance describe --mirror_poses: they need it"
                 : std::string(plane ? "--mirror_plane" : "--mirror_tolerance") +
                       " describes --mirror_poses: it needs it";
    return false;
  }
  if (!FLAGS_halfway_poses && given("halfway_min_bone_motion")) {
    *error = "--halfway_min_bone_motion describes --halfway_poses: it needs it";
    return false;
  }
  if (FLAGS_bone_mesh.empty()) {
    for (const char* flag : {"bone_name", "bone_clearance", "bone_moving_fraction"}) {
      if (given(flag)) {
        *error = std::string("--") + flag + " describes a bone: it needs --bone_mesh";
        return false;
      }
    }
  }
  if (FLAGS_cut.empty() && given("cut_margin")) {
    *error = "--cut_margin describes --cut: it needs it";
    return false;
  }
  options->mirror.plane = FLAGS_mirror_plane;
  options->mirror.tolerance = FLAGS_mirror_tolerance;
  options->halfway.enabled = FLAGS_halfway_poses;
  options->halfway.min_bone_motion = FLAGS_halfway_min_bone_motion;
  if (!PrepareTargetOptionsFromFlags(options, error)) return false;
  options->meshing.num_threads = FLAGS_threads;
  options->boundary.num_threads = FLAGS_threads;
  options->max_memory_bytes = MaxMemoryBytes();
  return true;
}

bool VolumetricTargetOptionsFromFlags(VolumetricTargetOptions* options, std::string* error) {
  options->relative_stiffness = FLAGS_attachment_stiffness;
  if (!ParseInvertedTargets(FLAGS_inverted_targets, &options->inverted_targets)) {
    *error = "--inverted_targets=" + FLAGS_inverted_targets + ": expected exact or mirror";
    return false;
  }
  options->solver.relative_force_tolerance = FLAGS_prepare_tolerance;
  return SolverMethodFromFlag(&options->solver, error);
}

bool PrepareTargetOptionsFromFlags(PrepareJobOptions* options, std::string* error) {
  if (!VolumetricTargetOptionsFromFlags(&options->targets, error)) return false;
  options->num_threads = FLAGS_threads;
  options->targets.num_threads = FLAGS_threads;
  return true;
}

FlagNames PrepareFlagNames() {
  FlagNames flags = CommonFlagNames();
  for (const char* prefix : {"meshing.", "boundary.", "targets."}) {
    const FlagNames nested = CommonFlagNames(prefix);
    flags.insert(flags.end(), nested.begin(), nested.end());
  }
  flags.insert(flags.end(),
               {{"meshing.spacing", "--spacing"},
                {"meshing.shell_thickness", "--shell"},
                {"min_elements_per_vertex", "--min_vertex_elements"},
                {"cut_margin", "--cut_margin"},
                {"cuts", "--cut"},
                {"mu", "--mu"},
                {"boundary.fixed_depth", "--fixed_depth"},
                {"boundary.bone_clearance", "--bone_clearance"},
                {"boundary.bones.name", "--bone_name"},
                {"boundary.bones.moving_fraction", "--bone_moving_fraction"},
                {"boundary.bones.pose_mesh_pattern", "--bone_poses"},
                {"boundary.bones.region_boxes", "--bone_region"},
                {"mirror.plane", "--mirror_plane"},
                {"mirror.tolerance", "--mirror_tolerance"},
                {"halfway.min_bone_motion", "--halfway_min_bone_motion"},
                {"targets.relative_stiffness", "--attachment_stiffness"},
                {"targets.inverted_targets", "--inverted_targets"},
                {"targets.solver.relative_force_tolerance", "--prepare_tolerance"}});
  return flags;
}

}  // namespace aqs
