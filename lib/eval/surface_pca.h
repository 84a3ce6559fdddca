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
  // The training surfaces' variance along each component (k): its squared singular
  // value divided by the number of surfaces.
  const Eigen::VectorXd& variances() const { return variances_; }

  // Least-squares coefficients of a surface (projection onto the basis).
  Eigen::VectorXd Encode(const Eigen::Matrix3Xd& surface) const;
  Eigen::Matrix3Xd Decode(const Eigen::VectorXd& coefficients) const;
  // Best fit to a subset of vertices (positions 3 x K of vertices[i]): least squares on
  // those rows only; the full surface.
  Eigen::Matrix3Xd FitToVertices(const std::vector<int>& vertices,
                                 const Eigen::Matrix3Xd& positions) const;
  // The same with a ridge penalty on the whitened coefficients (a Gaussian prior of
  // the training spread):  min_c |A c - b|^2 + ridge sum_j c_j^2 / variances_j,  A the
  // basis rows of the given vertices and b their positions minus the mean (3K numbers).
  // ridge is a squared length (per coordinate); 0: plain least squares, and where the
  // markers do not determine the coefficients (fewer than k independent rows), the
  // solution of least sum_j c_j^2 / variances_j (the limit of small ridges).
  Eigen::Matrix3Xd FitToVerticesRidge(const std::vector<int>& vertices,
                                      const Eigen::Matrix3Xd& positions, double ridge) const;

 private:
  Eigen::VectorXd mean_;
  Eigen::VectorXd variances_;
  Eigen::MatrixXd basis_;
};

// Ridge-regularized PCA for markers, with its weight chosen by leave-one-out over the
// training surfaces: for each candidate ridge, each training surface p is fitted by a
// PCA of the others (k components, at most P - 2) from its marker vertices alone, and
// the mean vertex distance over error_vertices (empty: all) is averaged over p. The
// candidate with the smallest average wins (the first on ties). Needs at least 3
// surfaces (CHECK) and one candidate.
struct RidgeChoice {
  double ridge = 0.0;
  double loo_error = 0.0;
  std::vector<double> candidates, errors;  // the whole curve, for the log
};
RidgeChoice ChooseRidgeLeaveOneOut(const std::vector<Eigen::Matrix3Xd>& surfaces, int k,
                                   const std::vector<int>& marker_vertices,
                                   const std::vector<int>& error_vertices,
                                   const std::vector<double>& candidates);

}  // namespace aqs

#endif  // AQS_EVAL_SURFACE_PCA_H_
