#include "model/fit_prior.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <glog/logging.h>

#include "geometry/points_near_model.h"
#include "model/active_model.h"
#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/option_checks.h"

namespace aqs {
namespace {

Eigen::Matrix<double, 6, 1> BoneParameters(const RigidTransform& transform) {
  const Eigen::AngleAxisd aa(transform.rotation);
  Eigen::Matrix<double, 6, 1> p;
  p.head<3>() = aa.angle() * aa.axis();
  p.tail<3>() = transform.translation;
  return p;
}

// Second moment of the columns of x about c (x: n x P).
Eigen::MatrixXd MomentAbout(const Eigen::MatrixXd& x, const Eigen::VectorXd& c) {
  const Eigen::MatrixXd centred = x.colwise() - c;
  return centred * centred.transpose() / static_cast<double>(x.cols());
}

void AppendRow(const std::string& head, const Eigen::VectorXd& values, std::string* out) {
  *out += head;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    *out += ' ';
    AppendDouble(values[i], out);
  }
  *out += '\n';
}

}  // namespace

bool GaussianPrior::SetCovariance(const Eigen::MatrixXd& c) {
  if (c.rows() != c.cols() || c.rows() != mean.size()) return false;
  if ((c - c.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(1.0, c.cwiseAbs().maxCoeff())) {
    return false;
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (c + c.transpose()));
  if (llt.info() != Eigen::Success) return false;
  const Eigen::MatrixXd l = llt.matrixL();
  if (l.diagonal().minCoeff() <= 0) return false;
  covariance = 0.5 * (c + c.transpose());
  whitening = l.triangularView<Eigen::Lower>().solve(
      Eigen::MatrixXd::Identity(c.rows(), c.cols()));
  return true;
}

double GaussianPrior::SquaredMahalanobis(const Eigen::VectorXd& x) const {
  return (whitening * (x - mean)).squaredNorm();
}

FitPrior LearnFitPrior(const ActiveModel& model, const FitPriorOptions& options) {
  FitPrior prior;
  std::string error;
  CHECK(LearnFitPrior(model, options, &prior, &error)) << error;
  return prior;
}

bool FitPriorOptions::Validate(std::string* error) const {
  return OptionChecks()
      .NonNegative("latent_floor", latent_floor)
      .NonNegative("rotation_floor", rotation_floor)
      .NonNegative("rotation_floor_fraction", rotation_floor_fraction)
      .NonNegative("translation_floor_fraction", translation_floor_fraction)
      .Done(error);
}

bool IsNeutralSurface(const Eigen::Matrix3Xd& surface, const Eigen::Matrix3Xd& neutral) {
  if (surface.cols() != neutral.cols() || neutral.cols() == 0) return false;
  const double diagonal = ModelSize(neutral);
  return (surface - neutral).colwise().norm().maxCoeff() <= 1e-6 * diagonal;
}

bool LearnLatentPrior(const Eigen::MatrixXd& latents, int center, const FitPriorOptions& options,
                      GaussianPrior* out, std::string* error) {
  CHECK_GT(latents.cols(), 0);
  CHECK_LT(center, latents.cols());
  const Eigen::Index d = latents.rows();
  GaussianPrior prior;
  prior.mean = center >= 0 ? Eigen::VectorXd(latents.col(center))
                           : Eigen::VectorXd(latents.rowwise().mean());
  Eigen::MatrixXd covariance = MomentAbout(latents, prior.mean);
  double mean_variance = covariance.trace() / d;
  if (std::isfinite(mean_variance) && mean_variance <= kNoLatentSpread) {
    // No spread to learn from (one training pose, or latents all alike): unit variance,
    // the scale of the whitened latents training starts from, not a prior that pins
    // every fit to the centre (1e-14 I before).
    covariance.setIdentity(d, d);
    mean_variance = 1.0;
  }
  covariance.diagonal().array() += options.latent_floor * mean_variance;
  if (!covariance.allFinite() || !prior.SetCovariance(covariance)) {
    *error = "the training latents are too far apart to give a latent prior (their second "
             "moment is not finite and positive definite)";
    return false;
  }
  *out = std::move(prior);
  return true;
}

bool LearnFitPrior(const ActiveModel& model, const FitPriorOptions& options, FitPrior* out,
                   std::string* error) {
  std::string invalid;
  CHECK(options.Validate(&invalid)) << "fit prior options: " << invalid;
  CHECK(model.decoder) << "a fit prior needs a trained model";
  const int num_poses = model.num_poses();
  const int d = model.latent_dim();
  if (num_poses == 0) {
    *error = "the model has no training poses to learn a fit prior from";
    return false;
  }
  FitPrior prior;
  // The neutral among the training poses.
  int center = -1;
  for (int p = 0; p < num_poses && center < 0; ++p) {
    if (IsNeutralSurface(model.poses[p].surface, model.neutral.vertices)) center = p;
  }
  prior.center = center >= 0 ? model.poses[center].name : "";
  CHECK_EQ(model.latents.rows(), d);
  if (!LearnLatentPrior(model.latents, center, options, &prior.latent, error)) return false;

  const Eigen::Vector3d lo = model.mesh.vertices.rowwise().minCoeff();
  const Eigen::Vector3d hi = model.mesh.vertices.rowwise().maxCoeff();
  const double mesh_diagonal = model.mesh.num_vertices() > 0 ? (hi - lo).norm() : 1.0;
  for (const Bone& bone : model.bones) {
    Eigen::MatrixXd params(6, num_poses);
    for (int p = 0; p < num_poses; ++p) params.col(p) = BoneParameters(bone.pose_transforms[p]);
    GaussianPrior g;
    g.mean = center >= 0 ? Eigen::VectorXd(params.col(center)) : Eigen::VectorXd::Zero(6);
    Eigen::MatrixXd cov = MomentAbout(params, g.mean);
    const double rotation_std = std::sqrt(cov.diagonal().head<3>().maxCoeff());
    const double translation_std = std::sqrt(cov.diagonal().tail<3>().maxCoeff());
    const double rotation_floor =
        std::max(options.rotation_floor, options.rotation_floor_fraction * rotation_std);
    const double translation_floor = std::max(options.translation_floor_fraction * translation_std,
                                              1e-3 * mesh_diagonal);
    for (int i = 0; i < 3; ++i) {
      cov(i, i) += rotation_floor * rotation_floor;
      cov(3 + i, 3 + i) += translation_floor * translation_floor;
    }
    if (!cov.allFinite() || !g.SetCovariance(cov)) {
      *error = "the motions of bone '" + bone.name + "' are too far apart to give a bone "
               "prior (their second moment is not finite and positive definite)";
      return false;
    }
    prior.bones.push_back(g);
  }
  *out = std::move(prior);
  return true;
}

bool WriteFitPrior(const std::string& path, const FitPrior& prior,
                   const std::vector<std::string>& bone_names, std::string* error) {
  CHECK_EQ(bone_names.size(), prior.bones.size());
  std::string text =
      "# ActiveQS fit prior (docs/model_format.md): Gaussians of the latent and of each bone's\n"
      "# rigid motion (rotation vector in radians, translation), used by every fit\n";
  text += "center " + (prior.center.empty() ? std::string("-") : prior.center) + "\n";
  AppendRow("latent_mean", prior.latent.mean, &text);
  for (int i = 0; i < prior.latent.size(); ++i) {
    AppendRow("latent_covariance " + std::to_string(i), prior.latent.covariance.row(i), &text);
  }
  for (size_t b = 0; b < prior.bones.size(); ++b) {
    AppendRow("bone " + bone_names[b] + " mean", prior.bones[b].mean, &text);
    for (int i = 0; i < 6; ++i) {
      AppendRow("bone " + bone_names[b] + " covariance " + std::to_string(i),
                prior.bones[b].covariance.row(i), &text);
    }
  }
  return WriteFileAtomically(path, text, error);
}

bool ReadFitPrior(const std::string& path, int latent_dim,
                  const std::vector<std::string>& bone_names, FitPrior* prior_out,
                  std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  std::map<std::string, int> bone_index;
  for (size_t b = 0; b < bone_names.size(); ++b) bone_index[bone_names[b]] = static_cast<int>(b);
  FitPrior prior;
  // Per block (latent = -1, bones 0..): the mean, the covariance rows seen, the line of
  // the last row (for errors about the whole matrix).
  struct Block {
    Eigen::VectorXd mean;
    Eigen::MatrixXd covariance;
    std::vector<bool> rows;
    int last_line = 0;
  };
  std::vector<Block> blocks(bone_names.size() + 1);
  for (size_t i = 0; i < blocks.size(); ++i) {
    const int n = i == 0 ? latent_dim : 6;
    blocks[i].covariance.setZero(n, n);
    blocks[i].rows.assign(n, false);
  }
  bool have_center = false;
  std::vector<std::string> t;
  auto parse_numbers = [&](size_t first, int n, Eigen::VectorXd* out) {
    if (t.size() != first + n) return false;
    out->resize(n);
    for (int i = 0; i < n; ++i) {
      if (!ParseDouble(t[first + i], &(*out)[i]) || !std::isfinite((*out)[i])) return false;
    }
    return true;
  };
  // Each line's kind ("center", "latent_covariance 3", "bone jaw mean", ...) and where
  // it first came: a second one would silently replace the first.
  std::map<std::string, int> seen;
  auto first_time = [&](const std::string& kind) {
    const auto [it, inserted] = seen.emplace(kind, reader.line_number());
    if (!inserted) {
      *error = reader.Where("a second '" + kind + "' line (the first is line " +
                            std::to_string(it->second) + ")");
    }
    return inserted;
  };
  while (reader.NextTokens(&t)) {
    Eigen::VectorXd values;
    if (t[0] == "center" && t.size() == 2) {
      if (!first_time("center")) return false;
      prior.center = t[1] == "-" ? "" : t[1];
      have_center = true;
      continue;
    }
    int block = -1, row = -1;
    size_t first = 0;
    bool is_mean = false;
    if (t[0] == "latent_mean") {
      block = 0;
      is_mean = true;
      first = 1;
    } else if (t[0] == "latent_covariance" && t.size() >= 2) {
      block = 0;
      if (!ParseInt(t[1], &row)) row = -2;
      first = 2;
    } else if (t[0] == "bone" && t.size() >= 3) {
      const auto it = bone_index.find(t[1]);
      if (it == bone_index.end()) {
        *error = reader.Where("the model has no bone '" + t[1] + "'");
        return false;
      }
      block = 1 + it->second;
      if (t[2] == "mean") {
        is_mean = true;
        first = 3;
      } else if (t[2] == "covariance" && t.size() >= 4) {
        if (!ParseInt(t[3], &row)) row = -2;
        first = 4;
      } else {
        *error = reader.Where("expected 'bone <name> mean p1 .. p6' or 'bone <name> covariance "
                              "<row> c1 .. c6'");
        return false;
      }
    } else {
      *error = reader.Where("expected center, latent_mean, latent_covariance or bone");
      return false;
    }
    Block& b = blocks[block];
    const int n = static_cast<int>(b.rows.size());
    if (!is_mean && (row < 0 || row >= n)) {
      *error = reader.Where("covariance row index must be in [0, " + std::to_string(n) + ")");
      return false;
    }
    if (!parse_numbers(first, n, &values)) {
      *error = reader.Where("expected " + std::to_string(n) + " finite numbers");
      return false;
    }
    std::string kind = t[0];
    for (size_t k = 1; k + 1 < first; ++k) kind += " " + t[k];
    if (first > 1) kind += " " + (is_mean ? t[first - 1] : std::to_string(row));
    if (!first_time(kind)) return false;
    if (is_mean) {
      b.mean = values;
    } else {
      b.covariance.row(row) = values.transpose();
      b.rows[row] = true;
      b.last_line = reader.line_number();
    }
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (!have_center) {
    *error = path + ": no 'center' line";
    return false;
  }
  for (size_t i = 0; i < blocks.size(); ++i) {
    const std::string what = i == 0 ? std::string("the latent") : "bone '" + bone_names[i - 1] + "'";
    Block& b = blocks[i];
    if (b.mean.size() == 0 ||
        std::find(b.rows.begin(), b.rows.end(), false) != b.rows.end()) {
      *error = path + ": " + what + " needs its mean and every covariance row";
      return false;
    }
    GaussianPrior g;
    g.mean = b.mean;
    if (!g.SetCovariance(b.covariance)) {
      *error = path + ":" + std::to_string(b.last_line) + ": the covariance of " + what +
               " is not symmetric positive definite";
      return false;
    }
    if (i == 0) {
      prior.latent = g;
    } else {
      prior.bones.push_back(g);
    }
  }
  *prior_out = std::move(prior);
  return true;
}

}  // namespace aqs
