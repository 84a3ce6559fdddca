#include "util/finite_values.h"

#include <cmath>

#include "util/number_format.h"

namespace aqs {

bool AllFiniteForWriting(const std::string& path, const Eigen::Ref<const Eigen::MatrixXd>& values,
                         const std::string& item, std::string* error) {
  for (Eigen::Index c = 0; c < values.cols(); ++c) {
    for (Eigen::Index r = 0; r < values.rows(); ++r) {
      if (!std::isfinite(values(r, c))) {
        *error = path + ": " + item + " " + std::to_string(c) +
                 " has a number that is not finite (" + FormatDouble(values(r, c)) +
                 "); nothing was written";
        return false;
      }
    }
  }
  return true;
}

}  // namespace aqs
