// The scenes of the contact tests (tests/contact/): obstacles, block models, and two
// soft balls pressed together.

#ifndef AQS_TESTING_CONTACT_SCENES_H_
#define AQS_TESTING_CONTACT_SCENES_H_

#include <vector>

#include <Eigen/Core>

#include "contact/contact_solver.h"
#include "geometry/embedding.h"
#include "geometry/rigid_transform.h"
#include "mesh/tet_mesh.h"
#include "model/active_model.h"

namespace aqs {
namespace testing {

// A point stencil over vertices first .. first + 3 with weights w and a fixed offset.
PointStencil Stencil(int first, const Eigen::Vector4d& w);

// An axis-aligned box surface (closed, outward), as an obstacle.
void BoxSurface(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, Eigen::Matrix3Xd* v,
                Eigen::Matrix3Xi* t);

// A prism along z in [-1, 1] (closed, outward) whose top has a concave crease: the profile
// (-1, -2), (1, -2), (1, 0), (0, -depth), (-1, 0) in (x, y), 0 < depth < 2, so the top's
// two faces meet along x = 0, y = -depth, at an angle of atan(depth) to the horizontal
// each (the crease is sharper than a right angle for depth > 1).
void NotchedPrismSurface(double depth, Eigen::Matrix3Xd* v, Eigen::Matrix3Xi* t);

// A model of lattice blocks with the given boundary conditions, its surface the mesh
// boundary (no training data: only what ContactSolver needs).
ActiveModel BlockModel(const TetMesh& mesh, const std::vector<int>& fixed);

// The equilibrium of a one-bone model at rest actuation with the bone moved by `push`
// (3 x num_vertices), without contact; false if it does not converge.
bool ContactFreeEquilibrium(const ActiveModel& model, const RigidTransform& push,
                            Eigen::Matrix3Xd* positions);

// Two soft balls, each a lattice under a smooth embedded sphere (as faces are modelled),
// in one model whose surface is both spheres (radius 0.5, centres 1.1 apart): the left
// ball held at its far side, the right one driven by its far side (bone "driver").
ActiveModel TwoBallsModel(int* surface_vertices_per_ball);

// Contact options of the two-balls tests: thickness 0.01, search radius 0.1.
ContactOptions BallsContactOptions(double max_depth);

// The two balls (TwoBallsModel) with the right one pushed towards the left one: the
// model, its surface vertices per ball, the driver bone's motion and the contact-free
// equilibrium there (3 x num_vertices).
struct PushedBalls {
  ActiveModel model;
  int surface_vertices_per_ball = 0;
  RigidTransform push;
  Eigen::Matrix3Xd free;
};

// The right ball pushed `distance` towards the left one, into *balls; false if the
// contact-free equilibrium does not converge.
bool PushBalls(double distance, PushedBalls* balls);

// Along the centre line of the balls at `state` (3 x num_vertices): the right ball's
// leftmost surface point minus the left ball's rightmost one (negative: they overlap).
double BallsGap(const PushedBalls& balls, const Eigen::Matrix3Xd& state);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_CONTACT_SCENES_H_
