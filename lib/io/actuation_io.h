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

// Writes `values` (6 x num_elements) in the same format, 17 significant digits, after
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
