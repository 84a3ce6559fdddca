#include "testing/training_fixtures.h"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

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

PretrainOptions SyntheticPretrainOptions(const SyntheticBarSpec& spec) {
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = spec.latent_dim;
  pretrain.spec.hidden_dims = {spec.hidden};
  pretrain.spec.activation = spec.activation;
  pretrain.spec.anchored = spec.anchored;
  pretrain.spec.linear_skip = spec.linear_skip;
  pretrain.field.node_spacing = spec.node_spacing;
  pretrain.max_iterations = spec.pretrain_iterations;
  pretrain.decoder_regularization = spec.decoder_regularization;
  pretrain.latent_start = spec.latent_start;
  pretrain.log_every = 0;
  return pretrain;
}

ActiveModel PretrainedSyntheticBar(const SyntheticBarSpec& spec, PretrainReport* report) {
  SyntheticMuscles data = MakeSyntheticMuscles(spec.num_poses, 0, 0.3, spec.seed);
  std::ostringstream log;
  std::string error;
  VolumetricTargetOptions targets;
  targets.num_threads = spec.num_threads;
  EXPECT_TRUE(MakeVolumetricTargets(targets, &data.model, log, &error)) << error;
  const PretrainOptions pretrain = SyntheticPretrainOptions(spec);
  PretrainReport own_report;
  EXPECT_TRUE(Pretrain(pretrain, &data.model, report != nullptr ? report : &own_report, log,
                       &error))
      << error;
  return data.model;
}

void WritePretrainedSyntheticModel(const std::string& path, int num_poses, unsigned seed,
                                   int hidden, int pretrain_iterations) {
  SyntheticBarSpec spec;
  spec.num_poses = num_poses;
  spec.seed = seed;
  spec.hidden = hidden;
  spec.pretrain_iterations = pretrain_iterations;
  const ActiveModel model = PretrainedSyntheticBar(spec);
  std::string error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
}

void ScaleCheckpointParameters(const std::string& directory, double factor) {
  std::ifstream in(directory + "/checkpoint.txt");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t line = text.find("\nparameters ");
  ASSERT_NE(line, std::string::npos) << directory << "/checkpoint.txt:\n" << text;
  const size_t at = line + 12;
  const std::string slot = directory + "/" + text.substr(at, text.find(' ', at) - at);
  std::ifstream slot_in(slot, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(slot_in)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 24u) << slot;
  for (size_t i = 24; i + sizeof(double) <= bytes.size(); i += sizeof(double)) {
    double value = 0.0;
    std::memcpy(&value, bytes.data() + i, sizeof(double));
    value *= factor;
    std::memcpy(&bytes[i], &value, sizeof(double));
  }
  std::ofstream(slot, std::ios::binary | std::ios::trunc) << bytes;
}

}  // namespace testing
}  // namespace aqs
