#ifndef AQS_IO_ACTUATION_IO_H_
#define AQS_IO_ACTUATION_IO_H_

#include <string>

#include <Eigen/Core>

#include "physics/actuation.h"

namespace aqs {

// Per-element text files: one line per element in mesh order; '#' starts a comment;
// blank lines are skipped. Errors name "path:line".

// Actuation file: six numbers per line, "sxx syy szz sxy sxz syz". Exactly
// num_elements lines; fewer or more is an error saying how many were found.
bool ReadActuation(const std::string& path, int num_elements, ActuationMatrix* a,
                   std::string* error);

// Bounds of the principal stretches (eigenvalues) of an actuation target S that
// ReadActuationTargets accepts: S must be positive definite, stretching by at least
// 1e-3 and at most 1e3 along every direction. Outside, an element is asked to collapse
// (S = 1e-12 I), turn inside out (S = -I) or blow up, and the "equilibrium" is one with
// inverted or degenerate elements, which is never what a user meant.
constexpr double kMinActuationStretch = 1e-3;
constexpr double kMaxActuationStretch = 1e3;

// The largest ratio of the stiffest to the softest element's mu that the jobs accept
// (per-element stiffness files, model files): beyond it the stiffness matrix is too
// ill-conditioned for double precision.
constexpr double kMaxStiffnessContrast = 1e12;

// ReadActuation for actuations that drive a simulation (aqs_simulate --actuation): also
// every S must be positive definite with eigenvalues in [kMinActuationStretch,
// kMaxActuationStretch]. Otherwise false with *error giving how many elements are out
// of range, and the first one's line, element and eigenvalues.
bool ReadActuationTargets(const std::string& path, int num_elements, ActuationMatrix* a,
                          std::string* error);

// Checks targets that prepare computed (a model's targets/NNNN.bin, the resume store's):
// every element's largest principal stretch in magnitude must lie in
// [kMinActuationStretch, kMaxActuationStretch]. Unlike ReadActuationTargets it accepts S
// that are not positive definite (prepare's exact targets of elements its embedded
// simulation inverts have a negative eigenvalue, a flat one a zero) but refuses a target
// collapsed along every direction (S = 0) or blown up (1e300): a damaged file. `a` is
// 6 x num_elements. False with *error naming `source`, the number of such elements and the
// first one's element index and eigenvalues.
bool CheckStoredTargets(const std::string& source, const ActuationMatrix& a, std::string* error);

// The number of elements of `a` whose S is not positive definite (smallest eigenvalue
// <= 0). *first (may be null) receives the first such element, or -1.
int CountNonPositiveDefinite(const ActuationMatrix& a, int* first = nullptr);

// Writes `values` (6 x num_elements) in the same format, each number as the shortest
// text that reads back exactly (util/number_format.h); false with *error naming the
// element if a number is not finite (nothing is written). After
// '#' comment lines `header` (may be empty; may contain several lines). Used for
// actuations and for gradients dL/d(sxx syy szz sxy sxz syz).
bool WriteActuation(const std::string& path, const ActuationMatrix& values,
                    const std::string& header, std::string* error);

// One number per line, exactly `count` lines (e.g. a per-element stiffness mu). With
// require_positive, zero or negative values are errors naming the line.
bool ReadScalarsPerLine(const std::string& path, int count, bool require_positive,
                        Eigen::VectorXd* values, std::string* error);

}  // namespace aqs

#endif  // AQS_IO_ACTUATION_IO_H_
