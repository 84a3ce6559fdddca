#include "contact/read_obstacles.h"

#include "geometry/points_near_model.h"
#include "geometry/surface_components.h"

namespace aqs {

bool ReadMovingObstacles(const std::string& spec, const ActiveModel& model,
                         std::vector<MovingObstacle>* obstacles, std::ostream& log,
                         std::string* error) {
  std::vector<ObstacleSpec> specs;
  if (!ParseObstacleSpecs(spec, &specs, error)) return false;
  std::vector<Eigen::Matrix3Xd> obstacle_vertices;
  std::vector<Eigen::Matrix3Xi> obstacle_triangles;
  if (!ReadObstacleSurfaces(specs, &obstacle_vertices, &obstacle_triangles, error)) return false;
  for (size_t i = 0; i < specs.size(); ++i) {
    if (!CheckPointsNearModel(specs[i].path, model.neutral.vertices, obstacle_vertices[i],
                              error)) {
      return false;
    }
    MovingObstacle obstacle;
    obstacle.name = specs[i].path;
    obstacle.vertices = obstacle_vertices[i];
    obstacle.triangles = obstacle_triangles[i];
    if (!specs[i].bone.empty()) {
      for (size_t k = 0; k < model.bones.size(); ++k) {
        if (model.bones[k].name == specs[i].bone) obstacle.bone = static_cast<int>(k);
      }
      if (obstacle.bone < 0) {
        *error = "obstacle " + specs[i].path + ": the model has no bone '" + specs[i].bone + "'";
        return false;
      }
    }
    // One obstacle per closed shell: a file of teeth holds one shell per tooth, and
    // neighbours overlap (their union is no closed surface of its own).
    const std::vector<MovingObstacle> shells = SplitIntoShells(obstacle);
    obstacles->insert(obstacles->end(), shells.begin(), shells.end());
    log << "obstacle " << specs[i].path << ": " << obstacle_triangles[i].cols() << " triangles"
        << (shells.size() > 1 ? " in " + std::to_string(shells.size()) + " shells" : "")
        << (specs[i].bone.empty() ? "" : ", moving with " + specs[i].bone) << "\n";
    // An open shell encloses nothing well defined: an open patch gave no contact, exit 0
    // and no word.
    for (const MovingObstacle& shell : shells) {
      int open_edges = 0;
      for (const BoundaryLoop& loop : FindBoundaryLoops(shell.triangles)) {
        open_edges += loop.num_edges();
      }
      if (open_edges > 0) {
        log << "obstacle " << shell.name << ": warning: not closed (" << open_edges
            << " edges of one triangle only): contact pushes points out of what a closed "
               "surface encloses, and points may pass through this one\n";
      }
    }
  }
  return true;
}

}  // namespace aqs
