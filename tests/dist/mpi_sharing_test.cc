// The collectives of the MPI world and the model's sharing among ranks (run by mpirun
// with 2 ranks): another model on one rank is refused naming the rank, and rank 0's
// learned state replaces the others'.

#include <gtest/gtest.h>

#include "dist/communicator.h"
#include "dist/model_sharing.h"
#include "dist/mpi_world.h"
#include "model/fit_prior.h"
#include "model/model_fingerprint.h"

namespace aqs {
namespace {

using testing::World;

TEST(MpiCommunicatorTest, CollectivesCombineEveryRank) {
  const Communicator& world = World();
  const int n = world.size(), r = world.rank();
  double sums[2] = {1.0 + r, 0.5 * r};
  world.SumToRoot(sums, 2);
  if (world.is_root()) {
    EXPECT_EQ(sums[0], n + n * (n - 1) / 2.0);
    EXPECT_EQ(sums[1], 0.25 * n * (n - 1));
  }
  double all[1] = {1.0 + r};
  world.SumToAll(all, 1);
  EXPECT_EQ(all[0], n + n * (n - 1) / 2.0);
  double largest[1] = {-1.0 * r};
  world.MaxToAll(largest, 1);
  EXPECT_EQ(largest[0], 0.0);
  int smallest[1] = {10 - r};
  world.MinToAll(smallest, 1);
  EXPECT_EQ(smallest[0], 10 - (n - 1));
  // Rank r sends r + 1 numbers r, r, ...
  std::vector<int> counts(n);
  for (int k = 0; k < n; ++k) counts[k] = k + 1;
  const std::vector<double> send(r + 1, r);
  std::vector<double> received(n * (n + 1) / 2, -1.0);
  world.GatherToRoot(send.data(), counts, received.data());
  if (world.is_root()) {
    size_t i = 0;
    for (int k = 0; k < n; ++k) {
      for (int j = 0; j <= k; ++j) EXPECT_EQ(received[i++], k);
    }
  }
  std::string text = world.is_root() ? std::string("from rank 0 \0 with a zero byte", 30) : "";
  world.BroadcastText(&text, 0);
  EXPECT_EQ(text, std::string("from rank 0 \0 with a zero byte", 30));
  std::string error = "rank's own failure";
  EXPECT_TRUE(world.Agree(true, &error));
  // The lowest failing rank's message reaches every rank.
  const int failing = n - 1;
  error = r == failing ? "cannot read x" : "";
  EXPECT_FALSE(world.Agree(r == failing ? false : true, &error));
  EXPECT_EQ(error, (failing > 0 ? "rank " + std::to_string(failing) + ": " : std::string()) +
                       "cannot read x");
}

TEST(MpiSharingTest, AnotherModelOnOneRankIsRefusedNamingTheRank) {
  const Communicator& world = World();
  const int last = world.size() - 1;
  ActiveModel model = testing::PretrainedBar(2);
  if (world.rank() == last && last > 0) model.poses[1].surface(0, 3) += 1e-9;
  std::string error;
  const bool ok = ShareModel(world, "DIR", true, &model, &error);
  ASSERT_GT(last, 0);
  EXPECT_FALSE(ok);
  EXPECT_EQ(error, "rank " + std::to_string(last) + ": the model at DIR is another model than "
                   "rank 0's (another mesh, fixed vertices, bones, embedding or pose set): every "
                   "rank must read the same model (copy the whole directory to every machine)");
}

// A neutral.obj triangulated otherwise on one rank (ModelFingerprint leaves the faces
// out; point-cloud fits read them).
TEST(MpiSharingTest, OtherNeutralFacesOnOneRankAreRefused) {
  const Communicator& world = World();
  const int last = world.size() - 1;
  ActiveModel model = testing::PretrainedBar(2);
  if (world.rank() == last && last > 0) {
    model.neutral.triangles.col(0).reverseInPlace();
  }
  std::string error;
  const bool ok = ShareModel(world, "DIR", true, &model, &error);
  ASSERT_GT(last, 0);
  EXPECT_FALSE(ok);
  EXPECT_NE(error.find("rank " + std::to_string(last) + ": the model at DIR has a neutral.obj "
                       "with other faces than rank 0's"),
            std::string::npos)
      << error;
}

// The first item unlike rank 0's, on each rank.
TEST(MpiCommunicatorTest, FirstItemUnlikeRootNamesTheFirstDifference) {
  const Communicator& world = World();
  const int r = world.rank();
  EXPECT_EQ(world.FirstItemUnlikeRoot({"a 1", "b 2", "c 3"}), -1);
  EXPECT_EQ(world.FirstItemUnlikeRoot({"a 1", r == 0 ? "b 2" : "b 9", "c 3"}), r == 0 ? -1 : 1);
  std::vector<std::string> items = {"a", "b"};
  if (r > 0) items.pop_back();  // fewer items than rank 0
  int root_count = -1;
  EXPECT_EQ(world.FirstItemUnlikeRoot(items, &root_count), r == 0 ? -1 : 1);
  EXPECT_EQ(root_count, 2);
  // More items than rank 0: the first difference is rank 0's count.
  items = {"a", "b"};
  if (r > 0) items.push_back("c");
  EXPECT_EQ(world.FirstItemUnlikeRoot(items, &root_count), r == 0 ? -1 : 2);
  EXPECT_EQ(root_count, 2);
  EXPECT_EQ(world.FirstItemUnlikeRoot({}, &root_count), -1);
  EXPECT_EQ(root_count, 0);
}

TEST(MpiSharingTest, AnotherDecoderOnOneRankIsRefused) {
  const Communicator& world = World();
  const int last = world.size() - 1;
  ActiveModel model = testing::PretrainedBar(2);
  if (world.rank() == last && last > 0) {
    DecoderSpec spec = model.decoder->spec();
    spec.hidden_dims = {9};
    model.decoder = std::make_shared<ActuationDecoder>(spec, model.decoder->field());
    model.decoder_params = Eigen::VectorXd::Zero(model.decoder->num_parameters());
  }
  std::string error;
  const bool ok = ShareModel(world, "DIR", true, &model, &error);
  ASSERT_GT(last, 0);
  EXPECT_FALSE(ok);
  EXPECT_NE(error.find("rank " + std::to_string(last) + ": the model at DIR has another decoder"),
            std::string::npos) << error;
}

TEST(MpiSharingTest, ALoadFailureOnOneRankStopsEveryRank) {
  const Communicator& world = World();
  const int last = world.size() - 1;
  ActiveModel model;
  std::string error = world.rank() == last ? "DIR/mesh.mesh: cannot open" : "";
  EXPECT_FALSE(ShareModel(world, "DIR", world.rank() != last, &model, &error));
  EXPECT_EQ(error, (last > 0 ? "rank " + std::to_string(last) + ": " : std::string()) +
                       "DIR/mesh.mesh: cannot open");
}

// Every rank ends with rank 0's decoder parameters, latents, states and checkpoint,
// whatever its own copy held.
// A model without stored equilibria (pre-trained without simulating its poses) stays
// without them on every rank, with rank 0's learned-state fingerprint: a store keyed on
// it (the held-out fits) is found again by a run with another number of ranks.
TEST(MpiSharingTest, NoStoredEquilibriaStayNone) {
  const Communicator& world = World();
  ActiveModel model = testing::PretrainedBar(3);
  model.states.clear();
  const uint64_t before = LearnedStateFingerprint(model);
  std::string error;
  EXPECT_TRUE(ShareModel(world, "DIR", true, &model, &error)) << error;
  EXPECT_TRUE(model.states.empty());
  EXPECT_EQ(LearnedStateFingerprint(model), before);
}

TEST(MpiSharingTest, RankZerosLearnedStateReachesEveryRank) {
  const Communicator& world = World();
  ActiveModel model = testing::PretrainedBar(3);
  model.states.assign(3, Eigen::Matrix3Xd());
  model.states[2] = model.mesh.vertices;
  std::string error;
  // Every rank's own fit prior (another machine's copy may hold an older prior.txt).
  EXPECT_TRUE(LearnFitPrior(model, FitPriorOptions(), &model.fit_prior, &error)) << error;
  model.fit_prior.center = "rank " + std::to_string(world.rank());
  if (world.is_root()) {
    model.decoder_params.array() += 0.25;
    model.latents(1, 2) = 7.0;
    model.states[0] = model.mesh.vertices.array() + 0.5;
    model.checkpoint.iterations = 12;
    model.checkpoint.loss = 0.125;
    model.fit_prior.latent.mean.array() += 0.5;
    EXPECT_TRUE(model.fit_prior.latent.SetCovariance(2.0 * model.fit_prior.latent.covariance));
  }
  const ActiveModel root_copy = model;
  EXPECT_TRUE(ShareModel(world, "DIR", true, &model, &error)) << error;
  // Rank 0's numbers, compared on rank 0 after gathering a checksum from every rank.
  const double mine[7] = {model.decoder_params.sum(),
                          model.latents.sum(),
                          model.states[0].cols() > 0 ? model.states[0].sum() : -1.0,
                          model.checkpoint.loss * model.checkpoint.iterations,
                          model.fit_prior.latent.mean.sum(),
                          model.fit_prior.latent.whitening.sum(),
                          model.fit_prior.center == "rank 0" ? 1.0 : 0.0};
  std::vector<double> all(7 * world.size());
  world.GatherToRoot(mine, std::vector<int>(world.size(), 7), all.data());
  if (!world.is_root()) return;
  EXPECT_EQ(model.states[1].cols(), 0);
  for (int r = 0; r < world.size(); ++r) {
    EXPECT_EQ(all[7 * r + 0], root_copy.decoder_params.sum()) << "rank " << r;
    EXPECT_EQ(all[7 * r + 1], root_copy.latents.sum()) << "rank " << r;
    EXPECT_EQ(all[7 * r + 2], root_copy.states[0].sum()) << "rank " << r;
    EXPECT_EQ(all[7 * r + 3], 1.5) << "rank " << r;
    EXPECT_EQ(all[7 * r + 4], root_copy.fit_prior.latent.mean.sum()) << "rank " << r;
    EXPECT_EQ(all[7 * r + 5], root_copy.fit_prior.latent.whitening.sum()) << "rank " << r;
    EXPECT_EQ(all[7 * r + 6], 1.0) << "rank " << r << ": rank 0's prior centre";
  }
}

// Rank 0's bone priors and its checkpoint's next latent refit reach every rank (the other
// sharing tests' model had no bone, and nothing read the refit mark on other ranks).
TEST(MpiSharingTest, RankZerosBonePriorAndRefitMarkReachEveryRank) {
  const Communicator& world = World();
  ActiveModel model = testing::PretrainedBar(3);
  Bone bone;
  bone.name = "b";
  bone.pose_transforms.assign(model.num_poses(), RigidTransform());
  model.bones.push_back(bone);
  std::string error;
  EXPECT_TRUE(LearnFitPrior(model, FitPriorOptions(), &model.fit_prior, &error)) << error;
  ASSERT_EQ(model.fit_prior.bones.size(), 1u);
  if (world.is_root()) {
    model.fit_prior.bones[0].mean.array() += 0.25;
    model.checkpoint.latent_refit_at = 6;
  }
  EXPECT_TRUE(ShareModel(world, "DIR", true, &model, &error)) << error;
  double mine[2] = {model.fit_prior.bones[0].mean.sum(),
                    static_cast<double>(model.checkpoint.latent_refit_at)};
  std::vector<double> all(2 * world.size());
  world.GatherToRoot(mine, std::vector<int>(world.size(), 2), all.data());
  if (!world.is_root()) return;
  for (int r = 0; r < world.size(); ++r) {
    EXPECT_EQ(all[2 * r], all[0]) << "rank " << r;
    EXPECT_EQ(all[2 * r + 1], 6.0) << "rank " << r;
  }
}

}  // namespace
}  // namespace aqs
