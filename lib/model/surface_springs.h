#ifndef AQS_MODEL_SURFACE_SPRINGS_H_
#define AQS_MODEL_SURFACE_SPRINGS_H_

#include <Eigen/Core>

#include "model/active_model.h"

namespace aqs {

// The stiffness of a spring at each neutral surface vertex of `model` that, per unit
// area, is as stiff as `relative_stiffness` layers of elements: k_i = relative_stiffness
// x mean_e(mu_e) x A_i / h, with A_i the vertex's share of the neutral surface's area
// (VertexAreas: a third of each incident triangle's) and h the mesh's mean edge length
// (MeanEdgeLength). Vertices in no triangle get the mean area. num_surface_vertices
// values. Prepare's attachment springs (prepare/volumetric_targets.h) and the contact
// penalty's (contact/contact_solver.h) are these.
Eigen::VectorXd SurfaceSpringStiffness(const ActiveModel& model, double relative_stiffness);

}  // namespace aqs

#endif  // AQS_MODEL_SURFACE_SPRINGS_H_
