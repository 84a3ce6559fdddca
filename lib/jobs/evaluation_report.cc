#include "jobs/evaluation_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "util/number_format.h"

namespace aqs {

const char* const kEvaluationMethods[kNumEvaluationMethods] = {"physics", "autoencoder", "pca",
                                                               "pca_neutral"};
const char* const kNeutralMethod = "neutral";

namespace {

std::string FixedDecimals(double v, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, v);
  return text;
}

// How the auto-encoder's hidden layers compare with the decoder's, for the report.
std::string LayoutNote(const std::vector<int>& decoder, const std::vector<int>& autoencoder) {
  if (decoder == autoencoder) return "the same network layout";
  auto widths = [](const std::vector<int>& w) {
    if (w.empty()) return std::string("none (linear)");
    std::string text;
    for (size_t i = 0; i < w.size(); ++i) text += (i ? "," : "") + std::to_string(w[i]);
    return text;
  };
  return "hidden layers " + widths(autoencoder) + " (the physics decoder's: " + widths(decoder) +
         ")";
}

// How the auto-encoder's linear skip compares with the decoder's, for the report.
std::string SkipNote(bool decoder, bool autoencoder) {
  if (decoder == autoencoder) return decoder ? " and the same linear skip" : "";
  return autoencoder ? " and a linear skip (the physics decoder has none)"
                     : " and no linear skip (the physics decoder has one)";
}

// The rows of one split as pose -> method -> row (*table), with the poses in their first
// row's order (*poses). False if the split has no rows.
bool GroupBySplit(const std::vector<EvaluationRow>& rows, const std::string& split,
                  std::vector<std::string>* poses,
                  std::map<std::string, std::map<std::string, EvaluationRow>>* table) {
  for (const EvaluationRow& row : rows) {
    if (row.split != split) continue;
    if (table->find(row.pose) == table->end()) poses->push_back(row.pose);
    (*table)[row.pose][row.method] = row;
  }
  return !poses->empty();
}

}  // namespace

Eigen::VectorXd VertexErrors(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return (a - b).colwise().norm().transpose();
}

EvaluationRow SummarizeErrors(const std::string& split, const std::string& pose,
                              const std::string& method, const Eigen::VectorXd& errors,
                              const std::vector<int>& vertices) {
  EvaluationRow row;
  row.split = split;
  row.pose = pose;
  row.method = method;
  double sum = 0, squares = 0, worst = 0;
  int n = 0;
  auto add = [&](double e) {
    sum += e;
    squares += e * e;
    worst = std::max(worst, e);
    ++n;
  };
  if (vertices.empty()) {
    for (Eigen::Index i = 0; i < errors.size(); ++i) add(errors[i]);
  } else {
    for (int v : vertices) add(errors[v]);
  }
  row.mean = n > 0 ? sum / n : 0;
  row.rms = n > 0 ? std::sqrt(squares / n) : 0;
  row.max = worst;
  return row;
}

int TableDecimals(const std::vector<EvaluationRow>& rows) {
  std::vector<double> means;
  for (const EvaluationRow& row : rows) {
    if (std::isfinite(row.mean) && row.mean > 0) means.push_back(row.mean);
  }
  if (means.empty()) return kMinTableDecimals;
  std::nth_element(means.begin(), means.begin() + means.size() / 2, means.end());
  const double median = means[means.size() / 2];
  const int decimals = 2 - static_cast<int>(std::floor(std::log10(median)));
  return std::clamp(decimals, kMinTableDecimals, kMaxTableDecimals);
}

std::string EvaluationTable(const std::vector<EvaluationRow>& rows, const std::string& split) {
  const int decimals = TableDecimals(rows);
  const auto number = [decimals](double v) { return FixedDecimals(v, decimals); };
  std::vector<std::string> poses;
  std::map<std::string, std::map<std::string, EvaluationRow>> table;
  if (!GroupBySplit(rows, split, &poses, &table)) return "";
  std::string out = "| " + split +
                    " pose | neutral mean | physics mean | rms | max | autoencoder mean | "
                    "rms | max | PCA mean | rms | max | PCA (neutral) mean | rms | max |\n"
                    "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  // A method without a row for a pose (its fit failed) shows n/a there, and its mean,
  // which must be over every pose to compare with the others', is n/a too.
  std::map<std::string, EvaluationRow> average;
  std::map<std::string, int> count;
  for (const std::string& pose : poses) {
    out += "| " + pose;
    for (const std::string& method : std::vector<std::string>{kNeutralMethod}) {
      const auto it = table[pose].find(method);
      out += " | " + (it == table[pose].end() ? std::string("n/a") : number(it->second.mean));
      if (it != table[pose].end()) {
        average[method].mean += it->second.mean / poses.size();
        ++count[method];
      }
    }
    for (const char* method : kEvaluationMethods) {
      const auto it = table[pose].find(method);
      if (it == table[pose].end()) {
        out += " | n/a | n/a | n/a";
        continue;
      }
      const EvaluationRow& r = it->second;
      out += " | " + number(r.mean) + " | " + number(r.rms) + " | " + number(r.max);
      EvaluationRow& a = average[method];
      a.mean += r.mean / poses.size();
      a.rms += r.rms / poses.size();
      a.max = std::max(a.max, r.max);
      ++count[method];
    }
    out += " |\n";
  }
  const int all = static_cast<int>(poses.size());
  out += "| **mean** (max of max) | " +
         (count[kNeutralMethod] == all ? number(average[kNeutralMethod].mean) : "n/a");
  for (const char* method : kEvaluationMethods) {
    const EvaluationRow& a = average[method];
    if (count[method] == all) {
      out += " | **" + number(a.mean) + "** | " + number(a.rms) + " | " + number(a.max);
    } else {
      out += " | n/a | n/a | " + (count[method] > 0 ? number(a.max) : std::string("n/a"));
    }
  }
  out += " |\n";
  return out;
}

std::string ErrorBudgetTable(const std::vector<EvaluationRow>& rows, const std::string& split,
                             const std::vector<std::pair<std::string, std::string>>& columns) {
  const int decimals = TableDecimals(rows);
  const auto number = [decimals](double v) { return FixedDecimals(v, decimals); };
  std::vector<std::string> poses;
  std::map<std::string, std::map<std::string, EvaluationRow>> table;
  if (!GroupBySplit(rows, split, &poses, &table)) return "";
  std::string out = "| " + split + " pose |";
  std::string rule = "|---|";
  for (const auto& column : columns) {
    out += " " + column.second + " |";
    rule += "---:|";
  }
  out += "\n" + rule + "\n";
  std::vector<double> sum(columns.size(), 0.0), worst(columns.size(), 0.0);
  std::vector<int> count(columns.size(), 0);
  for (const std::string& pose : poses) {
    out += "| " + pose;
    for (size_t c = 0; c < columns.size(); ++c) {
      const auto it = table[pose].find(columns[c].first);
      if (it == table[pose].end()) {
        out += " | n/a";
        continue;
      }
      out += " | " + number(it->second.mean);
      sum[c] += it->second.mean;
      worst[c] = std::max(worst[c], it->second.max);
      ++count[c];
    }
    out += " |\n";
  }
  out += "| **mean**";
  for (size_t c = 0; c < columns.size(); ++c) {
    out += count[c] == static_cast<int>(poses.size()) ? " | **" + number(sum[c] / count[c]) + "**"
                                                       : std::string(" | n/a");
  }
  out += " |\n| max vertex error";
  for (size_t c = 0; c < columns.size(); ++c) {
    out += count[c] > 0 ? " | " + number(worst[c]) : std::string(" |");
  }
  out += " |\n";
  return out;
}

EvaluationTables MakeEvaluationTables(const std::vector<EvaluationRow>& rows,
                                      const EvaluationReportParts& parts) {
  EvaluationTables tables;
  tables.train = EvaluationTable(rows, "train");
  tables.test = EvaluationTable(rows, "test");
  if (!parts.error_budget) return tables;
  std::ostringstream b;
  b << "## Error budget\n\n"
    << "Where the physics model's error comes from (mean vertex error over the same "
    << parts.num_error_vertices << " vertices). **(a) floor**: the pose's own volumetric target "
    << "(prepare's embedded simulation of the pose) simulated: what a decoder that reproduced "
    << "the targets exactly would reach on this simulation mesh and embedding (a reference, "
    << "not a lower bound: other actuations may come closer). **(b) after pre-training**: the "
    << "pre-trained decoder's actuation of the pose's latent, simulated (pre-training fits the "
    << "targets, not the surfaces). **(c) trained**: the end-to-end trained model simulated "
    << "(the physics column above). (c) - (a) is what the decoder and its latent space still "
    << "miss; (b) - (c) what end-to-end training recovered.\n\n"
    << ErrorBudgetTable(rows, "train",
                        {{kNeutralMethod, "neutral"}, {"floor", "(a) floor"},
                         {"pretrain", "(b) after pre-training"}, {"physics", "(c) trained"}});
  if (!parts.have_pretrain) {
    b << "\n(b) is not recorded in this model: it is measured when pre-training ends "
      << "(`--pretrain_simulate`, pretrain/surface_errors.* in the model directory).\n";
  }
  if (parts.pretrain_unconverged > 0) {
    b << "\n" << parts.pretrain_unconverged << " training pose(s) had no equilibrium when "
      << "pre-training ended: their (b) is n/a, and so is its mean.\n";
  }
  if (parts.trained_iterations == 0) {
    b << "\nThis model is pre-trained only (no end-to-end training iteration): (c) is its "
      << "pre-trained decoder simulated again.\n";
  }
  if (!parts.test_names.empty()) {
    b << "\nHeld-out poses: **floor**: the pose's own volumetric target, made by prepare's "
      << "embedded simulation with the bones where the physics fit put them, simulated; "
      << "**physics fit**: latent and bones fitted through the simulator. physics - floor is "
      << "what the learned latent space misses of this pose.\n\n"
      << ErrorBudgetTable(rows, "test",
                          {{kNeutralMethod, "neutral"}, {"floor", "floor"},
                           {"physics", "physics fit"}, {"autoencoder", "autoencoder"},
                           {"pca", "PCA"}, {"pca_neutral", "PCA (neutral)"}});
    if (!parts.have_held_out_floor) b << "\n(The held-out floor could not be made; see the log.)\n";
  }
  if (parts.floor_failures > 0) {
    b << "\n" << parts.floor_failures << " floor equilibria did not converge and are left out "
      << "(n/a).\n";
  }
  if (parts.floor_without_fit > 0) {
    b << "\n" << parts.floor_without_fit << " held-out floor(s) are left out (n/a): the "
      << "physics fit failed, and the floor takes the bones where it puts them.\n";
  }
  tables.budget = b.str();
  return tables;
}

std::string EvaluationMarkdown(const EvaluationReportParts& parts, const EvaluationTables& tables) {
  std::ostringstream md;
  md << "# Evaluation of " << parts.model << "\n\n"
     << "Vertex distances between each method's surface and the pose (model units), over "
     << parts.num_error_vertices
     << " surface vertices. **neutral**: the rest surface itself (no motion), for reference. "
     << "Latent size " << parts.latent_dim << " for every method: "
     << "**physics** (this model: training latents, or latent and bone motion fitted to the "
     << "held-out pose through the simulator), **autoencoder** (surface-only decoder with "
     << LayoutNote(parts.decoder_hidden_dims, parts.autoencoder_hidden_dims)
     << (parts.decoder_anchored ? " and the same anchoring" : "")
     << SkipNote(parts.decoder_linear_skip, parts.autoencoder_linear_skip)
     << ", trained on the same poses, latent fitted with the physics fit's prior rule), "
     << "**PCA** (linear, "
     << parts.pca_components << " components about the training poses' mean, projection), "
     << "**PCA (neutral)** (linear, " << parts.pca_neutral_components
     << " components of the displacements from the neutral, uncentered: its zero is the "
     << "neutral, like an anchored decoder's zero latent).";
  if (parts.num_bones > 0) {
    md << " Besides its latent the physics model has its bones' rigid motions (6 numbers per "
       << "bone, " << parts.num_bones << (parts.num_bones > 1 ? " bones" : " bone")
       << "): on training poses their measured motions, on held-out poses fitted with "
       << "their prior; the surface baselines have none.";
  }
  md << "\n\n";
  md << "The auto-encoder trained " << parts.autoencoder_iterations << " L-BFGS iterations"
     << (parts.autoencoder_scaled_steps ? " with scaled steps" : "") << " from seed "
     << parts.autoencoder_seed;
  if (parts.autoencoder_restarts > 0) {
    md << ", restarted " << parts.autoencoder_restarts << " time"
       << (parts.autoencoder_restarts > 1 ? "s" : "")
       << " where L-BFGS stalled (the physics training's rule)";
  }
  md << ", loss " << parts.autoencoder_initial_loss << " -> " << parts.autoencoder_final_loss
     << " (" << parts.autoencoder_termination << ")";
  if (parts.autoencoder_resumed_after > 0) {
    md << "; it resumed a stopped run's checkpoint after iteration "
       << parts.autoencoder_resumed_after << " (loss " << parts.autoencoder_resumed_loss;
    if (parts.autoencoder_iterations > parts.autoencoder_resumed_after) {
      md << "; L-BFGS' memory starts empty there, so the result differs a little from an "
         << "uninterrupted run's)";
    } else {
      md << "; the checkpoint was the finished training, so the result is that run's)";
    }
  }
  md << ".\n\n";
  if (!parts.overlap_note.empty()) md << "**Warning:** " << parts.overlap_note << "\n\n";
  if (!parts.test_names.empty()) {
    md << "Held-out latent fits start, for the physics model and the auto-encoder alike, from "
       << (parts.training_pose_starts
               ? "the best of the mean training latent and each training pose's latent (and, for "
                 "the physics model, its bone motions and equilibrium) by the fit's own objective"
               : "the mean training latent (the physics model: bones at rest, from the rest shape)")
       << ":";
    for (size_t t = 0; t < parts.test_names.size(); ++t) {
      md << (t ? "; " : " ") << parts.test_names[t] << " from ";
      if (parts.physics_starts[t] == kFailedFitStart) {
        md << "(physics fit failed)";
      } else {
        md << parts.physics_starts[t];
      }
      md << " / " << parts.autoencoder_starts[t];
    }
    md << ". The physics model's and the auto-encoder's latents are fitted with the same "
       << "prior rule: ";
    if (parts.latent_prior > 0) {
      md << "a Gaussian learned from each model's own training latents (centred on the "
         << "neutral pose's latent, else their mean), weighted `--latent_prior` / min(points, "
         << "`--prior_points_cap`) = " << FormatDouble(parts.latent_prior);
      if (parts.prior_points_cap > 0) {
        md << " / min(points, " << FormatDouble(parts.prior_points_cap) << ")";
      } else {
        md << " / points (no cap)";
      }
    } else {
      md << "no latent prior (`--latent_prior=0`)";
    }
    if (parts.fit_latent_regularization > 0) {
      md << ", and " << FormatDouble(parts.fit_latent_regularization)
         << " |z|^2 (`--fit_regularization`)";
    }
    md << " (the physics model also fits its bones, with their prior).";
    if (parts.physics_fits_kept > 0) {
      md << " " << parts.physics_fits_kept << " of the " << parts.test_names.size()
         << " physics fits were a stopped run's, kept in its output folder (the same "
         << "model, learned state, fit options and poses: the same results).";
    }
    md << "\n\n";
  }
  md << "## Training poses\n\n" << tables.train << "\n";
  if (!tables.test.empty()) md << "## Held-out poses\n\n" << tables.test << "\n";
  if (parts.fit_failures > 0) {
    md << "**" << parts.fit_failures << " held-out physics fit(s) failed** and are left out "
       << "(n/a; the log says why).\n\n";
  }
  if (parts.error_budget) md << tables.budget << "\n";
  return md.str();
}

std::string EvaluationCsv(const std::vector<EvaluationRow>& rows) {
  std::string csv = "split,pose,method,mean,rms,max\n";
  for (const EvaluationRow& r : rows) {
    // Pose names may be as long as file names (they are checked not to hold ',').
    char numbers[80];
    std::snprintf(numbers, sizeof(numbers), ",%.17g,%.17g,%.17g\n", r.mean, r.rms, r.max);
    csv += r.split + "," + r.pose + "," + r.method + numbers;
  }
  return csv;
}

}  // namespace aqs
