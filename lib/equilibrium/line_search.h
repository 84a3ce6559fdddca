#ifndef AQS_EQUILIBRIUM_LINE_SEARCH_H_
#define AQS_EQUILIBRIUM_LINE_SEARCH_H_

#include <ostream>
#include <string>

namespace aqs {

// The backtracking line search of the energy minimizers (MinimizeEnergyNewton,
// MinimizeEnergyLbfgs): from the unit step along a descent direction d, t = 1, 1/2,
// 1/4, ... until E(x + t d) <= E(x) + armijo t dE/dx . d (sufficient decrease).
struct ArmijoLineSearch {
  int max_halvings = 30;  // halvings of one line search at most
  double armijo = 1e-4;   // the sufficient-decrease constant, in (0, 1/2)

  // Whether E(x + t d) = trial_energy decreases enough from E(x) = energy, for the
  // directional derivative slope = dE/dx . d < 0.
  bool SufficientDecrease(double energy, double trial_energy, double t, double slope) const {
    return trial_energy <= energy + armijo * t * slope;
  }
  // Checks the fields; false with *error naming the field.
  bool Validate(std::string* error) const;
};

// The stopping tests the Newton and L-BFGS energy minimizers share, in this order: a
// non-finite energy or force; the force (largest free-vertex |dE/dx|) at most
// force_tolerance (sets *converged); `count` steps of their kind (`what`, e.g.
// "factorization") at `limit`. true to stop, with the reason written to *message.
bool MinimizerShouldStop(double energy, double force, double force_tolerance, int count,
                         int limit, const char* what, std::ostream* message, bool* converged);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_LINE_SEARCH_H_
