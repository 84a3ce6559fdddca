#include "jobs/evaluation_report.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

TEST(EvaluationReportTest, SummarizesTheListedVerticesOrAll) {
  Eigen::Matrix3Xd a = Eigen::Matrix3Xd::Zero(3, 4), b = Eigen::Matrix3Xd::Zero(3, 4);
  b(0, 1) = 3.0;
  b(1, 1) = 4.0;  // vertex 1 is 5 away
  b(2, 3) = 1.0;  // vertex 3 is 1 away
  const Eigen::VectorXd errors = VertexErrors(a, b);
  ASSERT_EQ(errors.size(), 4);
  EXPECT_DOUBLE_EQ(errors[1], 5.0);

  const EvaluationRow all = SummarizeErrors("test", "smile", "physics", errors, {});
  EXPECT_EQ(all.split, "test");
  EXPECT_EQ(all.pose, "smile");
  EXPECT_EQ(all.method, "physics");
  EXPECT_DOUBLE_EQ(all.mean, 6.0 / 4);
  EXPECT_DOUBLE_EQ(all.rms, std::sqrt(26.0 / 4));
  EXPECT_DOUBLE_EQ(all.max, 5.0);

  const EvaluationRow some = SummarizeErrors("test", "smile", "physics", errors, {0, 3});
  EXPECT_DOUBLE_EQ(some.mean, 0.5);
  EXPECT_DOUBLE_EQ(some.rms, std::sqrt(0.5));
  EXPECT_DOUBLE_EQ(some.max, 1.0);
}

std::vector<EvaluationRow> TwoPoses() {
  std::vector<EvaluationRow> rows;
  double value = 0.01;
  for (const char* pose : {"a", "b"}) {
    rows.push_back({"test", pose, kNeutralMethod, 0.5, 0.6, 0.7});
    for (const char* method : kEvaluationMethods) {
      rows.push_back({"test", pose, method, value, 2 * value, 3 * value});
      value += 0.01;
    }
  }
  rows.push_back({"test", "a", "floor", 0.001, 0.002, 0.003});
  rows.push_back({"train", "c", "physics", 9, 9, 9});
  return rows;
}

TEST(EvaluationReportTest, TableHasARowPerPoseAndTheMeans) {
  const std::string table = EvaluationTable(TwoPoses(), "test");
  // physics of a: 0.01 / 0.02 / 0.03; of b: 0.05 / 0.10 / 0.15.
  EXPECT_NE(table.find("| a | 0.5000 | 0.0100 | 0.0200 | 0.0300 | 0.0200 |"), std::string::npos)
      << table;
  EXPECT_NE(table.find("| b | 0.5000 | 0.0500 | 0.1000 | 0.1500 |"), std::string::npos) << table;
  EXPECT_NE(table.find("| **mean** (max of max) | 0.5000 | **0.0300** | 0.0600 | 0.1500 |"),
            std::string::npos)
      << table;
  EXPECT_EQ(table.find("| c |"), std::string::npos) << "another split's pose";
  EXPECT_EQ(EvaluationTable(TwoPoses(), "none"), "");
}

// The tables print three significant digits at the rows' median error, whatever the
// model's unit: a face in metres (errors of 1e-4 to 1e-3) shows its differences, not
// 0.0001 for values 2x apart; one in cm keeps 4 decimals; the budget table agrees.
TEST(EvaluationReportTest, TablesPrintThreeDigitsAtTheMedianError) {
  std::vector<EvaluationRow> metres = TwoPoses();
  for (EvaluationRow& row : metres) {
    row.mean *= 0.01;
    row.rms *= 0.01;
    row.max *= 0.01;
  }
  EXPECT_EQ(TableDecimals(TwoPoses()), 4);
  EXPECT_EQ(TableDecimals(metres), 6);
  const std::string table = EvaluationTable(metres, "test");
  EXPECT_NE(table.find("| a | 0.005000 | 0.000100 | 0.000200 | 0.000300 | 0.000200 |"),
            std::string::npos)
      << table;
  const std::string budget = ErrorBudgetTable(metres, "test", {{"floor", "floor"}});
  EXPECT_NE(budget.find("| a | 0.000010 |"), std::string::npos) << budget;
  // Bounds: no positive error at all, and errors far below any unit's.
  EXPECT_EQ(TableDecimals({}), kMinTableDecimals);
  EXPECT_EQ(TableDecimals({{"test", "a", "physics", 0.0, 0.0, 0.0}}), kMinTableDecimals);
  EXPECT_EQ(TableDecimals({{"test", "a", "physics", 1e-30, 1e-30, 1e-30}}), kMaxTableDecimals);
  EXPECT_EQ(TableDecimals({{"test", "a", "physics", 123.0, 1, 1}}), kMinTableDecimals);
}

// A held-out fit that failed has no row: n/a in its place and for its method's mean,
// never a perfect 0.0000 averaged into the mean.
TEST(EvaluationReportTest, TableMarksAFailedFitNotAvailable) {
  std::vector<EvaluationRow> rows;
  for (const EvaluationRow& row : TwoPoses()) {
    if (!(row.pose == "b" && row.method == std::string("physics"))) rows.push_back(row);
  }
  const std::string table = EvaluationTable(rows, "test");
  EXPECT_NE(table.find("| b | 0.5000 | n/a | n/a | n/a | 0.0600 |"), std::string::npos) << table;
  EXPECT_NE(table.find("| **mean** (max of max) | 0.5000 | n/a | n/a | 0.0300 | **0.0400** |"),
            std::string::npos)
      << table;
  EXPECT_EQ(table.find("0.0000"), std::string::npos) << table;
}

TEST(EvaluationReportTest, BudgetTableMarksMissingStagesNotAvailable) {
  const std::string table =
      ErrorBudgetTable(TwoPoses(), "test", {{"floor", "floor"}, {"physics", "physics fit"}});
  EXPECT_NE(table.find("| test pose | floor | physics fit |"), std::string::npos) << table;
  EXPECT_NE(table.find("| a | 0.0010 | 0.0100 |"), std::string::npos) << table;
  EXPECT_NE(table.find("| b | n/a | 0.0500 |"), std::string::npos) << table;
  // The floor's mean needs every pose; the largest vertex error does not.
  EXPECT_NE(table.find("| **mean** | n/a | **0.0300** |"), std::string::npos) << table;
  EXPECT_NE(table.find("| max vertex error | 0.0030 | 0.1500 |"), std::string::npos) << table;
}

TEST(EvaluationReportTest, MarkdownSaysWhatWasComparedAndCsvKeepsEveryDigit) {
  EvaluationReportParts parts;
  parts.model = "out/model";
  parts.num_error_vertices = 9409;
  parts.latent_dim = 8;
  parts.decoder_hidden_dims = {64, 64};
  parts.autoencoder_hidden_dims = {64, 64};
  parts.decoder_linear_skip = true;
  parts.test_names = {"a", "b"};
  parts.physics_starts = {"mean latent", "jawOpen"};
  parts.autoencoder_starts = {"jawOpen", "mean latent"};
  parts.error_budget = true;
  parts.floor_failures = 1;
  const std::vector<EvaluationRow> rows = TwoPoses();
  const EvaluationTables tables = MakeEvaluationTables(rows, parts);
  EXPECT_NE(tables.budget.find("## Error budget"), std::string::npos);
  EXPECT_NE(tables.budget.find("(b) is not recorded in this model"), std::string::npos);
  EXPECT_NE(tables.budget.find("1 floor equilibria did not converge"), std::string::npos);
  // A held-out floor left out because its fit failed (with bones) is said, not made with
  // the bones at rest as if they were where a fit put them.
  EXPECT_EQ(tables.budget.find("held-out floor(s) are left out"), std::string::npos);
  parts.floor_without_fit = 1;
  EXPECT_NE(MakeEvaluationTables(rows, parts)
                .budget.find("1 held-out floor(s) are left out (n/a): the physics fit failed"),
            std::string::npos);
  parts.floor_without_fit = 0;
  // (b)'s n/a and a pre-trained-only model's (c) are explained.
  EXPECT_EQ(tables.budget.find("had no equilibrium when pre-training ended"), std::string::npos);
  EXPECT_EQ(tables.budget.find("pre-trained only"), std::string::npos);
  parts.pretrain_unconverged = 2;
  parts.trained_iterations = 0;
  const std::string explained = MakeEvaluationTables(rows, parts).budget;
  EXPECT_NE(explained.find("2 training pose(s) had no equilibrium when pre-training ended"),
            std::string::npos);
  EXPECT_NE(explained.find("This model is pre-trained only"), std::string::npos);
  parts.pretrain_unconverged = 0;
  parts.trained_iterations = -1;
  const std::string md = EvaluationMarkdown(parts, tables);
  EXPECT_EQ(md.rfind("# Evaluation of out/model\n", 0), 0u) << md;
  EXPECT_NE(md.find("over 9409 surface vertices"), std::string::npos);
  EXPECT_NE(md.find("the same network layout"), std::string::npos);
  EXPECT_NE(md.find("and no linear skip (the physics decoder has one)"), std::string::npos);
  EXPECT_NE(md.find(": a from mean latent / jawOpen; b from jawOpen / mean latent."),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("## Held-out poses\n\n" + tables.test), std::string::npos);
  EXPECT_EQ(md.find("resumed"), std::string::npos) << md;
  EXPECT_EQ(md.find("stopped run"), std::string::npos) << md;
  // One prior rule for both learned models' fits, with the physics fit's weights.
  EXPECT_NE(md.find("b from jawOpen / mean latent. The physics model's and the auto-encoder's "
                    "latents are fitted with the same prior rule: no latent prior "
                    "(`--latent_prior=0`) (the physics model also fits its bones, with their "
                    "prior)."),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("latent fitted with the physics fit's prior rule"), std::string::npos) << md;
  parts.latent_prior = 0.03;
  parts.prior_points_cap = 200;
  EXPECT_NE(EvaluationMarkdown(parts, tables)
                .find("same prior rule: a Gaussian learned from each model's own training "
                      "latents (centred on the neutral pose's latent, else their mean), weighted "
                      "`--latent_prior` / min(points, `--prior_points_cap`) = 0.03 / min(points, "
                      "200) (the physics"),
            std::string::npos)
      << EvaluationMarkdown(parts, tables);
  parts.prior_points_cap = 0;
  parts.fit_latent_regularization = 1e-3;
  EXPECT_NE(EvaluationMarkdown(parts, tables)
                .find("= 0.03 / points (no cap), and 0.001 |z|^2 (`--fit_regularization`) (the"),
            std::string::npos)
      << EvaluationMarkdown(parts, tables);
  EXPECT_EQ(md.find("restarted"), std::string::npos) << md;
  parts.autoencoder_restarts = 3;
  EXPECT_NE(EvaluationMarkdown(parts, tables)
                .find(", restarted 3 times where L-BFGS stalled (the physics training's rule), "
                      "loss "),
            std::string::npos)
      << EvaluationMarkdown(parts, tables);
  parts.physics_fits_kept = 1;
  EXPECT_NE(EvaluationMarkdown(parts, tables)
                .find("with their prior). 1 of the 2 physics fits were a stopped "
                      "run's, kept in its output folder"),
            std::string::npos);
  // The physics model's bone parameters, which the surface baselines do not have, are
  // said (the comparison is of latent sizes; it was in a parenthesis on the fits only).
  EXPECT_EQ(EvaluationMarkdown(parts, tables).find("Besides its latent"), std::string::npos);
  parts.num_bones = 1;
  EXPECT_NE(EvaluationMarkdown(parts, tables)
                .find("Besides its latent the physics model has its bones' rigid motions (6 "
                      "numbers per bone, 1 bone): on training poses their measured motions, "
                      "on held-out poses fitted with their prior; the surface baselines have "
                      "none."),
            std::string::npos);
  parts.autoencoder_resumed_after = 432;
  parts.autoencoder_resumed_loss = 0.25;
  parts.autoencoder_iterations = 500;
  EXPECT_NE(EvaluationMarkdown(parts, tables)
                .find("; it resumed a stopped run's checkpoint after iteration 432 (loss "
                      "0.25; L-BFGS' memory starts empty there, so the result differs a little"),
            std::string::npos);
  // A checkpoint of the finished training gives that training's result, not a different one.
  parts.autoencoder_iterations = 432;
  const std::string finished = EvaluationMarkdown(parts, tables);
  EXPECT_NE(finished.find("(loss 0.25; the checkpoint was the finished training, so the result "
                          "is that run's)"),
            std::string::npos)
      << finished;
  EXPECT_EQ(finished.find("differs a little"), std::string::npos) << finished;
  // A failed physics fit has no start; it is said to have failed, not to start at "failed".
  parts.physics_starts = {kFailedFitStart, "jawOpen"};
  const std::string failed = EvaluationMarkdown(parts, tables);
  EXPECT_NE(failed.find(": a from (physics fit failed) / jawOpen; b from jawOpen"),
            std::string::npos)
      << failed;

  parts.error_budget = false;
  EXPECT_EQ(MakeEvaluationTables(rows, parts).budget, "");

  const std::string csv = EvaluationCsv({{"train", "c", "physics", 0.1, 1.0 / 3, 2}});
  EXPECT_EQ(csv, "split,pose,method,mean,rms,max\ntrain,c,physics,0.10000000000000001,"
                 "0.33333333333333331,2\n");
  // A pose named as long as a file name may be (rows were cut at 256 bytes).
  const std::string name(250, 'p');
  EXPECT_EQ(EvaluationCsv({{"test", name, "pca", -1.2345678901234567e-300, 0.5, 1}}),
            "split,pose,method,mean,rms,max\ntest," + name +
                ",pca,-1.2345678901234568e-300,0.5,1\n");
}

}  // namespace
}  // namespace aqs
