#ifndef AQS_PHYSICS_ACTUATION_FIELDS_H_
#define AQS_PHYSICS_ACTUATION_FIELDS_H_

#include "mesh/tet_mesh.h"
#include "physics/actuation.h"

namespace aqs {

// A smooth, non-trivial synthetic actuation for demos, tests and benchmarks: per
// element, S = Q diag(1 - A sin(pi u), 1 + A/2 cos(2 pi v), 1 + 0.3 A w) Q^T, where
// (u, v, w) in [0, 1]^3 is the element centroid within the mesh's bounding box and Q a
// rotation whose angle varies along u and w (a contracting fibre field that turns
// through the body). `amplitude` A is the peak strain (0.1 = 10%). 6 x num_tets.
ActuationMatrix SmoothFibreActuation(const TetMesh& mesh, double amplitude);

}  // namespace aqs

#endif  // AQS_PHYSICS_ACTUATION_FIELDS_H_
