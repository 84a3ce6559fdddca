#ifndef AQS_EVAL_SURFACE_PCA_H_
#define AQS_EVAL_SURFACE_PCA_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// Linear PCA of surface poses: pose ~ center + basis * c, with c in R^k. The center is the
// mean of the poses (classic PCA), or a given surface such as the neutral (PCA of the
// displacements from it, uncentered: then the zero coefficients give that surface
// exactly, as an anchored auto-decoder's zero latent does).
// Surfaces are 3 x N (the same vertex order); internally flattened to 3N vectors.
class SurfacePca {
 public:
  // The k leading components of the training surfaces about their mean (k <= number of
  // poses - 1), or about `center` if given (k <= number of poses); extra components are
  // dropped.
  SurfacePca(const std::vector<Eigen::Matrix3Xd>& surfaces, int k,
             const Eigen::Matrix3Xd* center = nullptr);

  int num_components() const { return static_cast<int>(basis_.cols()); }
  const Eigen::VectorXd& mean() const { return mean_; }
  const Eigen::MatrixXd& basis() const { return basis_; }  // 3N x k, orthonormal columns

  // Least-squares coefficients of a surface (projection onto the basis).
  Eigen::VectorXd Encode(const Eigen::Matrix3Xd& surface) const;
  Eigen::Matrix3Xd Decode(const Eigen::VectorXd& coefficients) const;
  // Best fit to a subset of vertices (positions 3 x K of vertices[i]): least squares on
  // those rows only; the full surface.
  Eigen::Matrix3Xd FitToVertices(const std::vector<int>& vertices,
                                 const Eigen::Matrix3Xd& positions) const;

 private:
  Eigen::VectorXd mean_;
  Eigen::MatrixXd basis_;
};

}  // namespace aqs

#endif  // AQS_EVAL_SURFACE_PCA_H_
