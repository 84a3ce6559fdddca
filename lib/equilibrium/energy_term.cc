#include "equilibrium/energy_term.h"

namespace aqs {

double TotalEnergyAndGradient(const ShapeTargetModel& model,
                              const std::vector<const EnergyTerm*>& terms,
                              const ShapeTargetModel::PositionsRef& x,
                              const ShapeTargetModel::ActuationRef& a,
                              Eigen::Matrix3Xd* gradient, int num_threads,
                              PolarCache* cache) {
  double energy = model.EnergyAndGradient(x, a, gradient, num_threads, cache);
  for (const EnergyTerm* term : terms) energy += term->AddEnergyAndGradient(x, gradient);
  return energy;
}

}  // namespace aqs
