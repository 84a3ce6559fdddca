#include "jobs/shared_pose_work.h"

#include <algorithm>
#include <memory>
#include <sstream>
#include <utility>

#include <glog/logging.h>

#include "prepare/target_store.h"

namespace aqs {
namespace {

// `block` of rank `owner` into rank 0's *received (resized to block's size there).
void SendToRoot(const Communicator& comm, int owner, const std::vector<double>& block,
                int size, std::vector<double>* received) {
  std::vector<int> counts(comm.size(), 0);
  counts[owner] = size;
  received->assign(comm.is_root() ? size : 0, 0.0);
  comm.GatherToRoot(block.data(), counts, received->data());
}

// Rank `owner`'s *message on rank 0 (and every rank), if it is not empty there.
void SendMessageToRoot(const Communicator& comm, int owner, std::string* message) {
  int failed = comm.rank() == owner && !message->empty() ? 1 : 0;
  comm.Broadcast(&failed, 1, owner);
  if (failed) comm.BroadcastText(message, owner);
}

}  // namespace

bool MakeVolumetricTargetsOnRanks(const Communicator& comm,
                                  const VolumetricTargetOptions& options, ActiveModel* model,
                                  std::ostream& log, std::string* error,
                                  std::vector<std::string>* unconverged) {
  const int rank = comm.rank(), size = comm.size();
  const bool root = comm.is_root();
  const int num_poses = model->num_poses();
  std::vector<std::string> failures(num_poses);
  TargetStore store;
  const bool storing = root && !options.store_directory.empty();
  bool ok = options.Validate(error) &&
            (!storing ||
             store.Open(options.store_directory, TargetStoreKey(options, *model), error));
  if (!comm.Agree(ok, error)) return false;
  // The same options (those that shape the targets) and model on every rank.
  const std::string key = VolumetricTargetFingerprint(options, *model);
  std::string root_key = key;
  comm.BroadcastText(&root_key, 0);
  if (key != root_key) {
    *error = "the volumetric targets' options or model differ from rank 0's (key " + key +
             " against " + root_key + "): every rank must be given the same flags";
  }
  if (!comm.Agree(key == root_key, error)) return false;
  // The poses rank 0 finds in its store; the others are made in rounds.
  std::vector<int> stored(num_poses, 0);
  for (int p = 0; storing && p < num_poses; ++p) {
    stored[p] = store.Load(p, model->mesh.num_tets(), &model->poses[p], &failures[p]) ? 1 : 0;
  }
  if (num_poses > 0) comm.Broadcast(stored.data(), num_poses, 0);
  std::vector<int> remaining;
  for (int p = 0; p < num_poses; ++p) {
    if (!stored[p]) remaining.push_back(p);
  }
  if (root && remaining.size() < static_cast<size_t>(num_poses)) {
    log << "  " << num_poses - remaining.size() << " of " << num_poses
        << " poses' targets were taken from " << options.store_directory
        << " (an earlier run of the same preparation)\n";
  }
  // A round deals each rank as many poses as the ranks' fewest threads, and rank 0 keeps
  // the round's targets before the next round starts: a stop loses at most the round's
  // (all made before being sent, the other ranks' targets were lost with any rank). A
  // round waits for its slowest pose: the price of keeping every round's.
  // The same on every rank (a rank's own num_threads may differ): the least.
  int threads = options.num_threads;
  if (size > 1) comm.MinToAll(&threads, 1);
  const size_t per_rank = static_cast<size_t>(std::max(1, threads));
  const size_t per_round = per_rank * size;
  if (root && size > 1 && !remaining.empty()) {
    log << "  " << remaining.size() << " poses shared among " << size << " ranks in rounds of "
        << per_round << " (rank 0 logs its own as they are made, then the others')\n";
  }
  std::unique_ptr<VolumetricTargetMaker> maker;  // made when a rank has poses to make
  const int elements = model->mesh.num_tets();
  const int block = 3 + 6 * elements;  // has target, mean, max, target (6 x elements)
  std::vector<double> send, received;
  for (size_t begin = 0; begin < remaining.size(); begin += per_round) {
    const size_t end = std::min(remaining.size(), begin + per_round);
    const auto owner_of = [&](size_t k) { return static_cast<int>((k - begin) / per_rank); };
    std::vector<int> mine;
    for (size_t k = begin; k < end; ++k) {
      if (owner_of(k) == rank) mine.push_back(remaining[k]);
    }
    std::ostringstream own_log;
    if (!mine.empty() && !maker) {
      maker = std::make_unique<VolumetricTargetMaker>(options, *model);
    }
    if (maker) {
      maker->Make(mine, storing ? &store : nullptr, model, root ? log : own_log, &failures);
    }
    if (size == 1) continue;
    // The other ranks' log lines of the round, in rank order.
    for (int r = 1; r < size; ++r) {
      std::string text = rank == r ? own_log.str() : std::string();
      comm.BroadcastText(&text, r);
      if (root) log << text;
    }
    // Their targets, one pose at a time, kept by rank 0 as they come.
    for (size_t k = begin; k < end; ++k) {
      const int owner = owner_of(k);
      if (owner == 0) continue;
      const int p = remaining[k];
      TrainingPose& pose = model->poses[p];
      send.assign(rank == owner ? block : 0, 0.0);  // only the owner sends
      if (rank == owner) {
        send[0] = pose.target.cols() == elements ? 1.0 : 0.0;
        send[1] = pose.embedding_mean_error;
        send[2] = pose.embedding_max_error;
        if (send[0] != 0) std::copy(pose.target.data(), pose.target.data() + 6 * elements,
                                    send.begin() + 3);
      }
      SendToRoot(comm, owner, send, block, &received);
      SendMessageToRoot(comm, owner, &failures[p]);
      if (!root) continue;
      pose.target.resize(6, received[0] != 0 ? elements : 0);
      if (received[0] != 0) {
        std::copy(received.begin() + 3, received.end(), pose.target.data());
      }
      pose.embedding_mean_error = received[1];
      pose.embedding_max_error = received[2];
      std::string store_error;
      if (storing && pose.target.cols() == elements &&
          !store.Save(p, pose, failures[p], &store_error)) {
        log << "  warning: pose '" << pose.name << "' not kept: " << store_error << "\n";
      }
    }
  }
  ok = true;
  if (root) {
    for (const std::string& failure : failures) {
      if (failure.empty()) continue;
      if (unconverged == nullptr) {
        *error = failure;
        ok = false;
        break;
      }
      unconverged->push_back(failure);
    }
  }
  return comm.Agree(ok, error);
}

std::vector<SimulatedPose> SimulateTrainingPosesOnRanks(const Communicator& comm,
                                                        const ActiveModel& model,
                                                        const PoseSimulationOptions& options) {
  CHECK(model.decoder != nullptr);
  const int rank = comm.rank(), size = comm.size();
  const int num_poses = model.num_poses();
  const std::vector<int> mine = OwnedIndices(num_poses, rank, size);
  std::vector<ActuationMatrix> actuations;
  std::vector<std::vector<RigidTransform>> bones;
  {
    // The whole batch, as one process decodes it (a batch of some latents rounds a little
    // differently); the others' actuations are freed before the simulations.
    std::vector<ActuationMatrix> all = DecodeTrainingLatents(model);
    for (int p : mine) {
      actuations.push_back(std::move(all[p]));
      bones.push_back(TrainingPoseBones(model, p));
    }
  }
  std::vector<SimulatedPose> own = SimulateActuations(model, actuations, bones, {}, options);
  if (size == 1) return own;
  // Every pose to rank 0: converged, state (3 x vertices), surface (3 x surface vertices).
  const int nv = model.mesh.num_vertices(), ns = model.num_surface_vertices();
  const int block = 1 + 3 * nv + 3 * ns;
  std::vector<SimulatedPose> results(comm.is_root() ? num_poses : 0);
  std::vector<double> send, received;
  for (int p = 0; p < num_poses; ++p) {
    const int owner = p % size;
    const int k = p / size;  // its index among the owner's poses
    if (owner == 0) {
      if (comm.is_root()) results[p] = std::move(own[k]);
      continue;
    }
    send.assign(rank == owner ? block : 0, 0.0);  // only the owner sends
    std::string message;
    if (rank == owner) {
      const SimulatedPose& pose = own[k];
      send[0] = pose.converged ? 1.0 : 0.0;
      std::copy(pose.state.data(), pose.state.data() + 3 * nv, send.begin() + 1);
      std::copy(pose.surface.data(), pose.surface.data() + 3 * ns, send.begin() + 1 + 3 * nv);
      message = pose.message;
    }
    SendToRoot(comm, owner, send, block, &received);
    SendMessageToRoot(comm, owner, &message);
    if (!comm.is_root()) continue;
    SimulatedPose& pose = results[p];
    pose.converged = received[0] != 0;
    pose.message = message;
    pose.state = Eigen::Map<const Eigen::Matrix3Xd>(received.data() + 1, 3, nv);
    pose.surface = Eigen::Map<const Eigen::Matrix3Xd>(received.data() + 1 + 3 * nv, 3, ns);
  }
  return results;
}

}  // namespace aqs
