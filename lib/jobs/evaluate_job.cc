#include "jobs/evaluate_job.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>

#include "eval/surface_pca.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "prepare/pose_files.h"
#include "train/progress.h"
#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

const char* const kMethods[3] = {"physics", "autoencoder", "pca"};
// The reference row of every pose: the neutral surface itself (no motion).
const char* const kNeutral = "neutral";

// Distances of the listed vertices (all if empty).
Eigen::VectorXd VertexErrors(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return (a - b).colwise().norm().transpose();
}

EvaluationRow Summarize(const std::string& split, const std::string& pose, const char* method,
                        const Eigen::VectorXd& errors, const std::vector<int>& vertices) {
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

std::string Number(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.4f", v);
  return text;
}

std::string MarkdownTable(const std::vector<EvaluationRow>& rows, const std::string& split) {
  // pose -> method -> row
  std::vector<std::string> poses;
  std::map<std::string, std::map<std::string, EvaluationRow>> table;
  for (const EvaluationRow& row : rows) {
    if (row.split != split) continue;
    if (table.find(row.pose) == table.end()) poses.push_back(row.pose);
    table[row.pose][row.method] = row;
  }
  if (poses.empty()) return "";
  std::string out = "| " + split + " pose | neutral mean | physics mean | rms | max | autoencoder mean | "
                    "rms | max | PCA mean | rms | max |\n"
                    "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  std::map<std::string, EvaluationRow> average;
  double neutral_average = 0;
  for (const std::string& pose : poses) {
    const auto neutral = table[pose].find(kNeutral);
    const double neutral_mean = neutral == table[pose].end() ? 0.0 : neutral->second.mean;
    neutral_average += neutral_mean / poses.size();
    out += "| " + pose + " | " + Number(neutral_mean);
    for (const char* method : kMethods) {
      const EvaluationRow& r = table[pose][method];
      out += " | " + Number(r.mean) + " | " + Number(r.rms) + " | " + Number(r.max);
      EvaluationRow& a = average[method];
      a.mean += r.mean / poses.size();
      a.rms += r.rms / poses.size();
      a.max = std::max(a.max, r.max);
    }
    out += " |\n";
  }
  out += "| **mean** (max of max) | " + Number(neutral_average);
  for (const char* method : kMethods) {
    const EvaluationRow& a = average[method];
    out += " | **" + Number(a.mean) + "** | " + Number(a.rms) + " | " + Number(a.max);
  }
  out += " |\n";
  return out;
}

}  // namespace

bool ParseVertexRanges(const std::string& text, std::vector<int>* vertices, std::string* error) {
  std::stringstream in(text);
  std::string item;
  std::vector<int> out;
  while (std::getline(in, item, ',')) {
    if (item.empty()) continue;
    const size_t colon = item.find(':'), dash = item.find('-');
    int a = 0, b = 0;
    if (colon != std::string::npos) {
      if (!ParseInt(item.substr(0, colon), &a) || !ParseInt(item.substr(colon + 1), &b) || b < a) {
        *error = "vertex range '" + item + "': expected a:b with a <= b";
        return false;
      }
    } else if (dash != std::string::npos && dash > 0) {
      if (!ParseInt(item.substr(0, dash), &a) || !ParseInt(item.substr(dash + 1), &b) || b < a) {
        *error = "vertex range '" + item + "': expected a-b with a <= b";
        return false;
      }
      ++b;
    } else {
      if (!ParseInt(item, &a)) {
        *error = "vertex range '" + item + "': not an index";
        return false;
      }
      b = a + 1;
    }
    if (a < 0) {
      *error = "vertex range '" + item + "': negative index";
      return false;
    }
    for (int v = a; v < b; ++v) out.push_back(v);
  }
  *vertices = out;
  return true;
}

bool RunEvaluateJob(const EvaluateJobOptions& options, std::ostream& log,
                    std::vector<EvaluationRow>* rows_out, std::string* error) {
  WallTimer total;
  if (options.model.empty() || options.output_directory.empty()) {
    *error = "--model and --output_dir are required";
    return false;
  }
  ActiveModel model;
  if (!LoadModel(options.model, &model, error)) return false;
  if (!model.decoder) {
    *error = options.model + ": the model is not trained (no decoder)";
    return false;
  }
  const int ns = model.num_surface_vertices();
  for (int v : options.error_vertices) {
    if (v >= ns) {
      *error = "error vertex " + std::to_string(v) + " is outside the surface's " +
               std::to_string(ns) + " vertices";
      return false;
    }
  }
  std::vector<std::string> test_names;
  std::vector<Eigen::Matrix3Xd> test_surfaces;
  if (!options.test_paths.empty() &&
      !ReadPoseSurfaces(options.test_paths, ns, options.num_threads, &test_names, &test_surfaces,
                        error)) {
    return false;
  }
  std::error_code code;
  const std::string out = options.output_directory;
  std::filesystem::create_directories(out + "/fields", code);
  std::filesystem::create_directories(out + "/fitted", code);
  if (code) {
    *error = out + ": cannot create the output folders (" + code.message() + ")";
    return false;
  }
  log << "evaluate: " << model.num_poses() << " training poses, " << test_names.size()
      << " held-out poses, latent " << model.latent_dim() << ", errors over "
      << (options.error_vertices.empty() ? ns : static_cast<int>(options.error_vertices.size()))
      << " surface vertices\n";

  // The baselines, trained on the same poses with the same latent size.
  std::vector<Eigen::Matrix3Xd> train_surfaces;
  for (const TrainingPose& pose : model.poses) train_surfaces.push_back(pose.surface);
  WallTimer timer;
  const SurfacePca pca(train_surfaces, model.latent_dim());
  SurfaceAutoencoderOptions ae_options = options.autoencoder;
  ae_options.latent_dim = model.latent_dim();
  ae_options.hidden_dims = model.decoder->spec().hidden_dims;
  ae_options.activation = model.decoder->spec().activation;
  SurfaceAutoencoder autoencoder;
  if (!autoencoder.Train(model.neutral.vertices, train_surfaces, ae_options, log, error)) {
    *error = "the auto-encoder baseline: " + *error;
    return false;
  }
  log << "baselines: PCA with " << pca.num_components() << " components; auto-encoder trained in "
      << FormatDuration(timer.Seconds()) << " (rms " << autoencoder.report().rms_error << ")\n";

  std::vector<EvaluationRow> rows;
  LatentFitter fitter(model, options.fit);
  // Training poses.
  for (int p = 0; p < model.num_poses(); ++p) {
    const Eigen::Matrix3Xd& truth = model.poses[p].surface;
    std::vector<RigidTransform> bones;
    for (const Bone& bone : model.bones) bones.push_back(bone.pose_transforms[p]);
    fitter.set_bone_transforms(bones);
    // From the equilibrium training left for this pose (the energy is not convex: from
    // rest a large pose such as jawOpen may crawl or reach another branch).
    fitter.StartFromTrainingPose(p);
    Eigen::Matrix3Xd state, surface;
    if (!fitter.Simulate(model.latents.col(p), &state, &surface, error)) {
      *error = "training pose '" + model.poses[p].name + "': " + *error;
      return false;
    }
    rows.push_back(Summarize("train", model.poses[p].name, kNeutral,
                             VertexErrors(model.neutral.vertices, truth), options.error_vertices));
    rows.push_back(Summarize("train", model.poses[p].name, "physics", VertexErrors(surface, truth),
                             options.error_vertices));
    rows.push_back(Summarize("train", model.poses[p].name, "autoencoder",
                             VertexErrors(autoencoder.Decode(autoencoder.training_latents().col(p)), truth),
                             options.error_vertices));
    rows.push_back(Summarize("train", model.poses[p].name, "pca",
                             VertexErrors(pca.Decode(pca.Encode(truth)), truth),
                             options.error_vertices));
  }
  // Held-out poses: fitted.
  std::vector<int> all(ns);
  for (int i = 0; i < ns; ++i) all[i] = i;
  for (size_t t = 0; t < test_names.size(); ++t) {
    WallTimer pose_timer;
    const Eigen::Matrix3Xd& truth = test_surfaces[t];
    fitter.set_bone_transforms(RestBoneTransforms(model));
    fitter.set_start_state(model.mesh.vertices);  // every fit from rest: order-independent
    LatentFitResult fit;
    if (!fitter.Fit(FullSurfaceTarget(truth), fitter.MeanLatent(), &fit, error)) {
      *error = "held-out pose '" + test_names[t] + "': " + *error;
      return false;
    }
    Eigen::VectorXd ae_latent;
    double ae_rms = 0;
    if (!autoencoder.FitLatent(all, truth, autoencoder.MeanLatent(), &ae_latent, &ae_rms)) {
      *error = "held-out pose '" + test_names[t] + "': the auto-encoder's latent fit failed";
      return false;
    }
    rows.push_back(Summarize("test", test_names[t], kNeutral,
                             VertexErrors(model.neutral.vertices, truth), options.error_vertices));
    const Eigen::Matrix3Xd surfaces[3] = {fit.surface, autoencoder.Decode(ae_latent),
                                          pca.Decode(pca.Encode(truth))};
    Eigen::VectorXd errors[3];
    for (int m = 0; m < 3; ++m) {
      errors[m] = VertexErrors(surfaces[m], truth);
      rows.push_back(Summarize("test", test_names[t], kMethods[m], errors[m], options.error_vertices));
    }
    log << "  " << test_names[t] << ": fitted in " << FormatDuration(pose_timer.Seconds())
        << " (physics " << fit.iterations << " iterations), mean error: neutral "
        << rows[rows.size() - 4].mean << ", physics "
        << rows[rows.size() - 3].mean << ", autoencoder " << rows[rows.size() - 2].mean << ", PCA "
        << rows.back().mean << "\n";
    if (!options.write_fields) continue;
    // One colour scale for the three methods of a pose: the 95th percentile of all
    // their vertex errors, so that the fields compare by eye.
    std::vector<double> pooled;
    for (const Eigen::VectorXd& e : errors) pooled.insert(pooled.end(), e.data(), e.data() + e.size());
    std::nth_element(pooled.begin(), pooled.begin() + pooled.size() * 95 / 100, pooled.end());
    const double color_max = std::max(1e-12, pooled[pooled.size() * 95 / 100]);
    for (int m = 0; m < 3; ++m) {
      SurfaceMesh surface = model.neutral;
      surface.vertices = surfaces[m];
      const std::string stem = test_names[t] + "_" + kMethods[m];
      const std::vector<double> values(errors[m].data(), errors[m].data() + errors[m].size());
      if (!WriteObj(out + "/fitted/" + stem + ".obj", surface, error) ||
          !WritePlyWithScalar(out + "/fields/" + stem + ".ply", surface, values, color_max, error)) {
        return false;
      }
    }
  }

  // Tables.
  std::ostringstream md;
  md << "# Evaluation of " << options.model << "\n\n"
     << "Vertex distances between each method's surface and the pose (model units), over "
     << (options.error_vertices.empty() ? ns : static_cast<int>(options.error_vertices.size()))
     << " surface vertices. **neutral**: the rest surface itself (no motion), for reference. "
     << "Latent size " << model.latent_dim() << " for all three methods: "
     << "**physics** (this model: training latents, or latent and bone motion fitted to the "
     << "held-out pose through the simulator), **autoencoder** (surface-only decoder with the "
     << "same network layout, trained on the same poses, latent fitted), **PCA** (linear, "
     << pca.num_components() << " components, projection).\n\n";
  const std::string train_table = MarkdownTable(rows, "train");
  const std::string test_table = MarkdownTable(rows, "test");
  md << "## Training poses\n\n" << train_table << "\n";
  if (!test_table.empty()) md << "## Held-out poses\n\n" << test_table << "\n";
  std::string csv = "split,pose,method,mean,rms,max\n";
  for (const EvaluationRow& r : rows) {
    char line[256];
    std::snprintf(line, sizeof(line), "%s,%s,%s,%.17g,%.17g,%.17g\n", r.split.c_str(),
                  r.pose.c_str(), r.method.c_str(), r.mean, r.rms, r.max);
    csv += line;
  }
  if (!WriteFileAtomically(out + "/evaluation.md", md.str(), error) ||
      !WriteFileAtomically(out + "/evaluation.csv", csv, error)) {
    return false;
  }
  log << "\n" << train_table << "\n" << test_table << "\nwrote " << out << "/evaluation.md, "
      << out << "/evaluation.csv" << (options.write_fields ? ", fields/*.ply, fitted/*.obj" : "")
      << " (" << FormatDuration(total.Seconds()) << ")\n";
  *rows_out = rows;
  return true;
}

}  // namespace aqs
