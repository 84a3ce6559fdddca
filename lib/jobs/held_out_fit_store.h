#ifndef AQS_JOBS_HELD_OUT_FIT_STORE_H_
#define AQS_JOBS_HELD_OUT_FIT_STORE_H_

// aqs_evaluate's held-out physics fits as blocks of numbers: what a rank sends to rank
// 0, and what the evaluation keeps as it goes (so that a rerun after a stop takes the
// fits already done). Internal to jobs/.

#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fit/latent_fit.h"
#include "jobs/evaluation_report.h"
#include "model/active_model.h"
#include "util/keyed_store.h"

namespace aqs {

// A fingerprint of a surface's points (3 x n, and n), as 16 hexadecimal digits: what
// the held-out fits' store and the ranks of a distributed evaluation compare poses by.
std::string SurfaceFingerprint(const Eigen::Matrix3Xd& surface);

// A held-out fit as one block of doubles for `model` (d = latent size, nb bones, nv
// simulation vertices, ns surface vertices): the latent (d), each bone's rotation
// (3 x 3, column-major) and translation (3), the equilibrium (3 x nv, column-major),
// the surface (3 x ns), then 8 numbers: rms, mean and max error, iterations, used
// points, converged (1/0), seconds, and the start (the training pose's index, -1 the
// mean latent, -2 a fit that failed: then every other number is 0).
int HeldOutFitBlockSize(const ActiveModel& model);

// Appends `fit` (fitted in `seconds`; its start "failed", kMeanLatentStart or a training
// pose's name) to *block as HeldOutFitBlockSize(model) numbers.
void PackHeldOutFit(const ActiveModel& model, const LatentFitResult& fit, double seconds,
                    std::vector<double>* block);

// The fit in `block` (HeldOutFitBlockSize(model) numbers) into *fit (its message is
// kept: blocks do not carry it) and *seconds. A failed fit becomes a LatentFitResult
// with failed = true, start "failed" and nothing else.
void UnpackHeldOutFit(const ActiveModel& model, const double* block, LatentFitResult* fit,
                      double* seconds);

// What the held-out fits belong to: the model as prepared (ModelFingerprint), its
// learned state (LearnedStateFingerprint), where fits start and the fit options
// (LatentFitOptions::KeyText).
std::string HeldOutFitKey(const ActiveModel& model, const LatentFitOptions& options,
                          bool training_pose_starts);

// The fits kept in a folder (util/keyed_store.h): NNNN.bin, the block (a column of
// util/matrix_io.h), then NNNN.txt, the record that makes it whole: "pose <name>",
// "surface <fingerprint of the target surface>" and "message <the fit's message>" (a
// failed fit's why, or the solver's termination; line breaks as spaces).
class HeldOutFitStore {
 public:
  // Opens (or empties, for another key) the folder and indexes the fits kept there by
  // pose and surface; false with *error.
  bool Open(const std::string& directory, const std::string& key, std::string* error);

  // The kept fit of pose `name` with this `surface` (3 x ns), if there is a whole one
  // (whatever its place in an earlier run's list: a pose added or removed does not
  // refit the others): fills *fit and *seconds and returns true. False (nothing
  // changed) otherwise, or when the files cannot be read.
  bool Load(const ActiveModel& model, const std::string& name, const Eigen::Matrix3Xd& surface,
            LatentFitResult* fit, double* seconds) const;

  // Keeps the fit of pose `name` with this `surface`: in its item if it has one, else in
  // a new one (an item of another pose is never replaced). False with *error if a file
  // cannot be written.
  bool Save(const ActiveModel& model, const std::string& name, const Eigen::Matrix3Xd& surface,
            const LatentFitResult& fit, double seconds, std::string* error);

  const std::string& directory() const { return store_.directory(); }

 private:
  KeyedStore store_;
  std::map<std::string, int> items_;  // pose name + "\n" + surface fingerprint -> item
  int next_item_ = 0;                 // the first item number not in use
};

}  // namespace aqs

#endif  // AQS_JOBS_HELD_OUT_FIT_STORE_H_
