#ifndef AQS_TESTING_TRAINING_FIXTURES_H_
#define AQS_TESTING_TRAINING_FIXTURES_H_

#include <string>
#include <utility>
#include <vector>

#include "learn/mlp.h"
#include "model/active_model.h"
#include "train/pretrain.h"

namespace aqs {
namespace testing {

// The rows of a training log (learned/log.csv: a header line, then one row per
// iteration starting "iteration,loss,..."): (iteration, loss) of every row that starts
// with two numbers, in file order. Empty if the file cannot be read.
std::vector<std::pair<int, double>> TrainingLogRows(const std::string& path);

// How PretrainedSyntheticBar makes its model.
struct SyntheticBarSpec {
  int num_poses = 4;
  unsigned seed = 11;
  int latent_dim = 2;
  int hidden = 8;                 // one hidden layer of this many units
  Activation activation = Activation::kElu;
  bool anchored = false;          // DecoderSpec::anchored
  bool linear_skip = false;       // DecoderSpec::linear_skip
  double node_spacing = 0.5;      // control nodes this far apart
  int pretrain_iterations = 30;
  double decoder_regularization = 0.0;  // PretrainOptions' weight decay
  PretrainLatentStart latent_start = PretrainLatentStart::kTargets;
  int num_threads = 2;
};

// The pre-training options PretrainedSyntheticBar uses for `spec` (no progress lines).
PretrainOptions SyntheticPretrainOptions(const SyntheticBarSpec& spec);

// The synthetic bar (testing/synthetic_muscles.h: MakeSyntheticMuscles(num_poses, 0,
// 0.3, seed)) with its volumetric targets and a small decoder pre-trained on them (no
// states; PretrainOptions' latent regularization), and the pre-training's report in
// *report if not null. Deterministic for a given spec. Adds a test failure on error.
ActiveModel PretrainedSyntheticBar(const SyntheticBarSpec& spec, PretrainReport* report = nullptr);

// A small pre-trained model of the synthetic bar, saved at `path` (a model directory):
// MakeSyntheticMuscles(num_poses, 0, 0.3, seed), its volumetric targets, and a decoder
// of latent size 2 and one hidden layer of `hidden` units (control nodes 0.5 apart)
// pre-trained for `pretrain_iterations`. Adds a test failure on error (use with
// ASSERT_NO_FATAL_FAILURE).
void WritePretrainedSyntheticModel(const std::string& path, int num_poses, unsigned seed,
                                   int hidden, int pretrain_iterations);

// Multiplies the numbers of the parameter slot that the solver checkpoint in `directory`
// (train/solver_checkpoint.h) names in its checkpoint.txt by `factor`, after the slot
// file's 24-byte header: finite numbers of another point than the one it recorded, as a
// damaged file holds. Adds a test failure if there is no such slot.
void ScaleCheckpointParameters(const std::string& directory, double factor);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_TRAINING_FIXTURES_H_
