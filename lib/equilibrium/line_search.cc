#include "equilibrium/line_search.h"

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

}  // namespace aqs
