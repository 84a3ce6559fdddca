#ifndef AQS_PHYSICS_STIFFNESS_ASSEMBLY_H_
#define AQS_PHYSICS_STIFFNESS_ASSEMBLY_H_

#include <vector>

#include <Eigen/Core>

#include "sparse/stiffness_pattern.h"
#include "physics/actuation.h"
#include "physics/shape_target_model.h"

namespace aqs {

enum class StiffnessKind {
  kExact,      // d2E/dx2 from the exact dP/dF (what implicit differentiation needs)
  kProjected,  // from the per-element PSD-projected dP/dF (positive semi-definite)
  // The Hessian with every element's rotation R held fixed: dP/dF = 2 mu I, i.e.
  // sum_e 2 mu_e V_e G_e^T G_e (G_e: x -> vec F_e). Independent of x and a (the matrix
  // of projective dynamics / as-rigid-as-possible global steps); positive definite
  // once fixed vertices remove the rigid motions of every mesh piece (a piece nothing
  // holds leaves it singular).
  kRotationFixed,
};

// Assembles the stiffness K = d2E/dx2 of `model` at positions x (3 x num_vertices) and
// actuation a (6 x num_elements) on the free DOFs of `pattern`, into `values`
// (resized to pattern.num_nonzeros(), upper-triangle CSC order of the pattern).
// Elements are processed in parallel on num_threads threads, each accumulating into
// its own copy of the values, summed at the end (memory: num_threads copies). The
// elements' SVDs are read from `cache` if it is non-null and matches (x, a).
void AssembleStiffness(const ShapeTargetModel& model, const StiffnessPattern& pattern,
                       const ShapeTargetModel::PositionsRef& x,
                       const ShapeTargetModel::ActuationRef& a, StiffnessKind kind,
                       int num_threads, std::vector<double>* values,
                       const PolarCache* cache = nullptr);

// The dense symmetric matrix (num_dofs x num_dofs) of upper-triangle CSC values, for
// tests and small problems.
Eigen::MatrixXd DenseFromUpperCsc(const StiffnessPattern& pattern,
                                  const std::vector<double>& values);

}  // namespace aqs

#endif  // AQS_PHYSICS_STIFFNESS_ASSEMBLY_H_
