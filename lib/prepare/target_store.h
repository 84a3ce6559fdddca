#ifndef AQS_PREPARE_TARGET_STORE_H_
#define AQS_PREPARE_TARGET_STORE_H_

#include <string>

#include "mesh/surface_mesh.h"
#include "model/active_model.h"
#include "prepare/volumetric_targets.h"
#include "util/keyed_store.h"

namespace aqs {

// Volumetric targets kept as they are made (VolumetricTargetOptions::store_directory),
// so that a prepare stopped in its embedded simulations (killed, out of time) resumes
// with the poses already done. A folder:
//
//   key.txt    what the targets belong to (VolumetricTargetKey): written first
//   NNNN.bin   pose NNNN's target (6 x num_elements, util/matrix_io.h)
//   NNNN.txt   "mean M", "max X" (the embedding errors) and, for a pose whose solve
//              did not converge, "failed <message>"; written after the .bin, so its
//              presence means the pose is done
//
// Every file is written atomically (util/keyed_store.h); the folder is removed once the
// model is saved (RemoveDirectory).

// What a pose's target depends on: the model as prepared so far (ModelFingerprint:
// mesh, mu, fixed vertices, bones, the neutral's vertices, embedding, poses) and the
// options that shape the solves (spring stiffness, continuation, solver method and
// tolerances). (The neutral's faces, which weigh the attachment springs, are not in it:
// models record its fingerprint; the store's key, TargetStoreKey, and aqs_prepare's
// check of an existing model add them.)
std::string VolumetricTargetKey(const VolumetricTargetOptions& options, const ActiveModel& model);

// The key of a target store (TargetStore::Open): VolumetricTargetKey and a hash of the
// neutral's faces (triangles and polygons), so that targets of other faces are not
// taken from a store.
std::string TargetStoreKey(const VolumetricTargetOptions& options, const ActiveModel& model);

// VolumetricTargetKey as 16 hexadecimal digits (an FNV-1a hash of its text): what
// ActiveModel::target_key records.
std::string VolumetricTargetFingerprint(const VolumetricTargetOptions& options,
                                        const ActiveModel& model);

// Where aqs_prepare keeps the targets of the model at `model_directory`: beside it,
// "<model>.aqs-targets" (the model folder itself is replaced as a whole at the end).
std::string TargetStorePath(const std::string& model_directory);

class TargetStore {
 public:
  // Opens `directory` (created if missing) for `key`. A folder that holds another key
  // (or none) is moved aside first, to KeyedStore::PreviousPath(directory): its targets
  // belong to something else, and are not deleted before this run has made its own.
  // Returns false with *error if the folder cannot be made or moved aside or key.txt
  // written.
  bool Open(const std::string& directory, const std::string& key, std::string* error);

  // Pose p's stored target, if there is a whole one of num_elements elements: fills
  // pose->target and its embedding errors, *failure ("" or the solve's message), and
  // returns true. False (nothing changed) if pose p is not stored or unreadable.
  bool Load(int p, int num_elements, TrainingPose* pose, std::string* failure) const;

  // Stores pose p's target and errors, with `failure` ("" if its solve converged).
  bool Save(int p, const TrainingPose& pose, const std::string& failure,
            std::string* error) const;

  const std::string& directory() const { return store_.directory(); }

 private:
  KeyedStore store_;
};

}  // namespace aqs

#endif  // AQS_PREPARE_TARGET_STORE_H_
