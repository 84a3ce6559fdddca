#ifndef AQS_IO_LATENT_IO_H_
#define AQS_IO_LATENT_IO_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/rigid_transform.h"

namespace aqs {

// Latent files (aqs_fit writes them, aqs_simulate --model reads them). Text; '#' starts
// a comment; the lines, in any order:
//   latent z_1 ... z_d
//   bone <name> r00 r01 r02 r10 r11 r12 r20 r21 r22 t0 t1 t2     (optional, per bone)
//   model <model fingerprint> <learned-state fingerprint>         (optional)
// Numbers are written as the shortest text that reads back exactly. A bone without a
// line stays at rest. The model line names the model the latent was fitted with
// (model/model_fingerprint.h, 16 hexadecimal digits each); files written before it
// existed have none.

// The model a latent file's latent belongs to: ModelFingerprint and
// LearnedStateFingerprint as text (FingerprintText); both empty: not recorded.
struct LatentFileModel {
  std::string model;
  std::string learned;
};

// Writes a latent, the named bones' transforms and (unless empty) `origin`. Atomic.
// False with *error naming the entry or bone if a number is not finite (nothing is
// written: the reader refuses them).
bool WriteLatentFile(const std::string& path, const Eigen::VectorXd& latent,
                     const std::vector<std::string>& bone_names,
                     const std::vector<RigidTransform>& bones, const std::string& comment,
                     const LatentFileModel& origin, std::string* error);

// Reads a latent of dimension latent_dim, the transforms of the bones named in
// bone_names (rest where the file has no line) and, into *origin (may be null), its
// model line (empty where it has none). Errors name path:line: a wrong count of latent
// numbers, an unknown bone, a rotation that is not a rotation (|R^T R - I| or det far
// from 1), a model line that is not two fingerprints, a repeated line, a missing latent
// line.
bool ReadLatentFile(const std::string& path, int latent_dim,
                    const std::vector<std::string>& bone_names, Eigen::VectorXd* latent,
                    std::vector<RigidTransform>* bones, LatentFileModel* origin,
                    std::string* error);

}  // namespace aqs

#endif  // AQS_IO_LATENT_IO_H_
