#ifndef AQS_CONTACT_FAR_DISPLACEMENT_H_
#define AQS_CONTACT_FAR_DISPLACEMENT_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// The largest of `moved` (one value per column of `surface`, 3 x n) over the points
// farther than `far_distance` (> 0) from every point i with touched[i] != 0 (every point
// when none is touched); 0 when no point is that far. ContactReport's
// max_far_displacement: how much a contact resolution moved the surface away from its
// contacts. Linear in n (a grid of the touched points; against each touched point it was
// quadratic on large surfaces).
double MaxFarDisplacement(const Eigen::Matrix3Xd& surface, const Eigen::VectorXd& moved,
                          const std::vector<char>& touched, double far_distance);

}  // namespace aqs

#endif  // AQS_CONTACT_FAR_DISPLACEMENT_H_
