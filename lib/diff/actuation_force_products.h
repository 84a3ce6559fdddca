#ifndef AQS_DIFF_ACTUATION_FORCE_PRODUCTS_H_
#define AQS_DIFF_ACTUATION_FORCE_PRODUCTS_H_

#include <Eigen/Core>

#include "physics/actuation.h"
#include "physics/shape_target_model.h"
#include "sparse/stiffness_pattern.h"

namespace aqs {

// The change of the nodal forces under actuation changes: for k directions v_c (columns
// of `directions`, (6 num_elements) x k, each an ActuationMatrix flattened column-major:
// element e's six numbers at rows 6e .. 6e+5), returns -B v_c on the free DOFs of
// `pattern` ((num_dofs) x k, free vertex f at rows 3f .. 3f+2), where
// B = d2E/(dx da) at (x, a): per element, V_e (dP/dS [dS_e]) b_j at its vertex j.
//
// Then dx*/da v = K^-1 (-B v) (the tangent of the equilibrium), and a state x* of a
// moved to a + v is predicted to first order by x* + K^-1 (-B v). The elements' SVDs
// are read from `cache` if it is non-null and matches (x, a).
Eigen::MatrixXd ActuationForceProducts(const ShapeTargetModel& model,
                                       const StiffnessPattern& pattern,
                                       const ShapeTargetModel::PositionsRef& x,
                                       const ShapeTargetModel::ActuationRef& a,
                                       const Eigen::MatrixXd& directions, int num_threads,
                                       const PolarCache* cache = nullptr);

}  // namespace aqs

#endif  // AQS_DIFF_ACTUATION_FORCE_PRODUCTS_H_
