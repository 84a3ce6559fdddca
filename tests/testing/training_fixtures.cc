#include "testing/training_fixtures.h"

#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "model/model_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "train/pretrain.h"

namespace aqs {
namespace testing {

std::vector<std::pair<int, double>> TrainingLogRows(const std::string& path) {
  std::vector<std::pair<int, double>> rows;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    int iteration = -1;
    double loss = 0;
    if (std::sscanf(line.c_str(), "%d,%lf", &iteration, &loss) == 2) rows.emplace_back(iteration, loss);
  }
  return rows;
}

void WritePretrainedSyntheticModel(const std::string& path, int num_poses, unsigned seed,
                                   int hidden, int pretrain_iterations) {
  SyntheticMuscles data = MakeSyntheticMuscles(num_poses, 0, 0.3, seed);
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(MakeVolumetricTargets(VolumetricTargetOptions(), &data.model, log, &error)) << error;
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 2;
  pretrain.spec.hidden_dims = {hidden};
  pretrain.field.node_spacing = 0.5;
  pretrain.max_iterations = pretrain_iterations;
  pretrain.log_every = 0;
  PretrainReport report;
  ASSERT_TRUE(Pretrain(pretrain, &data.model, &report, log, &error)) << error;
  ASSERT_TRUE(SaveModel(path, data.model, &error)) << error;
}

}  // namespace testing
}  // namespace aqs
