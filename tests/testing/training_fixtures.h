#ifndef AQS_TESTING_TRAINING_FIXTURES_H_
#define AQS_TESTING_TRAINING_FIXTURES_H_

#include <string>
#include <utility>
#include <vector>

namespace aqs {
namespace testing {

// The rows of a training log (learned/log.csv: a header line, then one row per
// iteration starting "iteration,loss,..."): (iteration, loss) of every row that starts
// with two numbers, in file order. Empty if the file cannot be read.
std::vector<std::pair<int, double>> TrainingLogRows(const std::string& path);

// A small pre-trained model of the synthetic bar, saved at `path` (a model directory):
// MakeSyntheticMuscles(num_poses, 0, 0.3, seed), its volumetric targets, and a decoder
// of latent size 2 and one hidden layer of `hidden` units (control nodes 0.5 apart)
// pre-trained for `pretrain_iterations`. Adds a test failure on error (use with
// ASSERT_NO_FATAL_FAILURE).
void WritePretrainedSyntheticModel(const std::string& path, int num_poses, unsigned seed,
                                   int hidden, int pretrain_iterations);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_TRAINING_FIXTURES_H_
