#include "equilibrium/line_search.h"

#include <cmath>
#include <sstream>

namespace aqs {

bool ArmijoLineSearch::Validate(std::string* error) const {
  std::ostringstream out;
  if (max_halvings < 0 || max_halvings > 60) {
    out << "max_halvings must be in [0, 60] (is " << max_halvings << ")";
  } else if (!(armijo > 0.0 && armijo < 0.5)) {
    out << "armijo must be in (0, 0.5) (is " << armijo << ")";
  }
  *error = out.str();
  return error->empty();
}

bool MinimizerShouldStop(double energy, double force, double force_tolerance, int count,
                         int limit, const char* what, std::ostream* message, bool* converged) {
  if (!std::isfinite(energy) || !std::isfinite(force)) {
    *message << "the energy or force is not finite";
    return true;
  }
  if (force <= force_tolerance) {
    *converged = true;
    *message << "force tolerance reached";
    return true;
  }
  if (count >= limit) {
    *message << what << " limit (" << limit << ") reached";
    return true;
  }
  return false;
}

}  // namespace aqs
