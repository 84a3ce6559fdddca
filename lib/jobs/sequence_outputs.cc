#include "jobs/sequence_outputs.h"

#include <algorithm>
#include <filesystem>
#include <limits>

#include <glog/logging.h>

#include "fit/bone_parameters.h"
#include "model/model_fingerprint.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/text_split.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

// A CSV number (read back bit for bit, util/number_format.h).
void Append(double v, std::string* out) {
  *out += ',';
  AppendDouble(v, out);
}

}  // namespace

std::string SequenceCsvHeader(const ActiveModel& model) {
  std::string h = "frame,name,kind,points,used_points,matched_fraction,mean_error,rms_error,"
                  "max_error,iterations,seconds,converged,start,factorizations";
  for (int i = 0; i < model.latent_dim(); ++i) h += ",z" + std::to_string(i + 1);
  for (const Bone& b : model.bones) {
    for (const char* p : {"rx", "ry", "rz", "tx", "ty", "tz"}) h += "," + b.name + "_" + p;
  }
  return h;
}

std::string SequenceTargetsText(const std::vector<SequenceFrame>& frames) {
  std::string text;
  for (const SequenceFrame& frame : frames) {
    text += frame.name + " " + FingerprintText(FrameTargetFingerprint(frame)) + "\n";
  }
  return text;
}

int FramesOfSameTargets(const std::string& recorded, const std::string& current, int num_done) {
  int same = 0;
  size_t at = 0;
  while (same < num_done) {
    const size_t end = current.find('\n', at);
    if (end == std::string::npos || end >= recorded.size() ||
        recorded.compare(at, end + 1 - at, current, at, end + 1 - at) != 0) {
      break;
    }
    at = end + 1;
    ++same;
  }
  return same;
}

bool ReadFramesDone(const std::string& csv, const std::string& output_dir,
                    const ActiveModel& model, const std::vector<SequenceFrame>& frames,
                    std::vector<DoneFrame>* done, std::string* error) {
  done->clear();
  if (!MayExist(csv)) return true;
  LineReader reader(csv);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  const std::string header = SequenceCsvHeader(model);
  const int d = model.latent_dim();
  const size_t columns = 14 + d + 6 * model.bones.size();
  while (reader.NextLine()) {
    if (reader.line_number() == 1) {
      if (reader.line() != header) {
        *error = reader.Where("written for another model (the header differs): remove the "
                              "folder or choose another --output_dir");
        return false;
      }
      continue;
    }
    const std::vector<std::string> cells = SplitFields(reader.line());
    const size_t f = done->size();
    int index = -1;
    if (cells.size() != columns || !ParseInt(cells[0], &index) || index != static_cast<int>(f)) {
      *error = reader.Where("expected the row of frame " + std::to_string(f) + " (" +
                            std::to_string(columns) + " columns)");
      return false;
    }
    if (f >= frames.size()) {
      *error = reader.Where("frame " + std::to_string(f) + " (" + cells[1] +
                           ") is done, but this sequence has " + std::to_string(frames.size()) +
                           " frames: the folder holds a longer sequence's fits; give that "
                           "whole sequence, or write to another --output_dir");
      return false;
    }
    if (cells[1] != frames[f].name) {
      *error = reader.Where("frame " + std::to_string(f) + " is '" + cells[1] +
                            "', but this sequence's is '" + frames[f].name +
                            "': the folder holds another run; remove it or choose another "
                            "--output_dir");
      return false;
    }
    DoneFrame row;
    row.line = reader.line();
    row.line_number = reader.line_number();
    row.failed = cells[11] == "-1";
    if (row.failed) {
      // Could not be fitted: no OBJ, "nan" for the matched fraction, the errors, the
      // latent and the bones.
      bool nans = true;
      for (size_t c = 5; c < cells.size() && nans; ++c) {
        nans = (c >= 9 && c < 14) || cells[c] == "nan";
      }
      if (!nans) {
        *error = reader.Where("a frame that could not be fitted (converged -1) has numbers "
                              "where 'nan' was written: the file is damaged; remove the "
                              "folder or choose another --output_dir");
        return false;
      }
      row.latent = Eigen::VectorXd::Constant(d, std::numeric_limits<double>::quiet_NaN());
      done->push_back(row);
      continue;
    }
    // Redo from the first frame whose OBJ is missing or empty (outputs are written
    // atomically, so an empty one was made by something else).
    std::error_code code;
    const std::string obj = output_dir + "/" + frames[f].name + ".obj";
    if (!fs::exists(obj, code) || fs::file_size(obj, code) == 0 || code) break;
    row.latent.resize(d);
    bool ok = true;
    for (int i = 0; i < d && ok; ++i) ok = ParseDouble(cells[14 + i], &row.latent[i]);
    for (size_t b = 0; b < model.bones.size() && ok; ++b) {
      double p[6];
      for (int k = 0; k < 6 && ok; ++k) ok = ParseDouble(cells[14 + d + 6 * b + k], &p[k]);
      if (ok) row.bones.push_back(BoneTransformFromParameters(p));
    }
    // The row's own figures (points ... factorizations, but the start's name): finite
    // numbers, as written.
    for (int c = 3; c < 14 && ok; ++c) {
      double value = 0.0;
      ok = c == 12 || ParseDouble(cells[c], &value);
    }
    if (!ok) {
      *error = reader.Where("a number of the row (a figure, the latent or a bone's motion) is "
                            "not a finite number: the file is damaged; remove the folder or "
                            "choose another --output_dir");
      return false;
    }
    done->push_back(row);
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  return true;
}

int FrameBlockSize(int d, int nb, int ns) { return kFrameScalars + d + 6 * nb + 3 * ns; }

void PackFrameBlock(const ActiveModel& model, const LatentFitResult& fit,
                    const std::string& start, double seconds, std::vector<double>* block) {
  int start_index = -3;
  if (start == "previous") {
    start_index = -2;
  } else if (start == "given") {
    start_index = -1;
  } else {
    for (int p = 0; p < model.num_poses() && start_index == -3; ++p) {
      if (model.poses[p].name == start) start_index = p;
    }
  }
  CHECK_NE(start_index, -3) << "unknown start " << start;
  *block = {double(fit.used_points), fit.matched_fraction, fit.mean_error, fit.rms_error,
            fit.max_error, double(fit.iterations), seconds, fit.converged ? 1.0 : 0.0,
            double(start_index), double(fit.solve_factorizations + fit.jacobians)};
  block->insert(block->end(), fit.latent.data(), fit.latent.data() + fit.latent.size());
  for (const RigidTransform& t : fit.bones) {
    double p[6];
    BoneTransformToParameters(t, p);
    block->insert(block->end(), p, p + 6);
  }
  block->insert(block->end(), fit.surface.data(), fit.surface.data() + fit.surface.size());
  CHECK_EQ(static_cast<int>(block->size()),
           FrameBlockSize(model.latent_dim(), static_cast<int>(model.bones.size()),
                          model.num_surface_vertices()));
}

void PackFailedFrameBlock(const ActiveModel& model, const LatentFitResult& fit,
                          const std::string& start, double seconds, std::vector<double>* block) {
  LatentFitResult counts;
  counts.iterations = fit.iterations;
  counts.solve_factorizations = fit.solve_factorizations;
  counts.jacobians = fit.jacobians;
  counts.latent.resize(model.latent_dim());
  counts.bones.resize(model.bones.size());
  counts.surface.resize(3, model.num_surface_vertices());
  PackFrameBlock(model, counts, start.empty() ? "given" : start, seconds, block);
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  for (int k : {1, 2, 3, 4}) (*block)[k] = kNan;
  (*block)[7] = kFrameFailed;
  if (start.empty()) (*block)[8] = -4.0;  // none chosen
  std::fill(block->begin() + kFrameScalars, block->end(), kNan);
}

std::string FrameCsvRow(const ActiveModel& model, int f, const SequenceFrame& frame,
                        const double* b) {
  const bool is_cloud = frame.kind == "points";
  const int start = static_cast<int>(b[8]);
  std::string row = std::to_string(f) + "," + frame.name + "," + frame.kind + "," +
                    std::to_string(is_cloud ? frame.cloud.cols() : frame.target.num_points()) +
                    "," + std::to_string(static_cast<int>(b[0]));
  for (int k = 1; k <= 4; ++k) Append(b[k], &row);
  row += "," + std::to_string(static_cast<int>(b[5]));
  Append(b[6], &row);
  row += std::string(",") + (BlockFailed(b) ? "-1" : b[7] != 0.0 ? "1" : "0") + "," +
         (start == -4   ? std::string("none")
          : start == -2 ? std::string("previous")
          : start == -1 ? std::string("given")
                        : model.poses[start].name) +
         "," + std::to_string(static_cast<int>(b[9]));
  const int values = model.latent_dim() + 6 * static_cast<int>(model.bones.size());
  for (int i = 0; i < values; ++i) Append(b[kFrameScalars + i], &row);
  return row;
}

Eigen::Map<const Eigen::VectorXd> BlockLatent(const ActiveModel& model, const double* b) {
  return Eigen::Map<const Eigen::VectorXd>(b + kFrameScalars, model.latent_dim());
}

Eigen::Map<const Eigen::Matrix3Xd> BlockSurface(const ActiveModel& model, const double* b) {
  const int offset = kFrameScalars + model.latent_dim() + 6 * static_cast<int>(model.bones.size());
  return Eigen::Map<const Eigen::Matrix3Xd>(b + offset, 3, model.num_surface_vertices());
}

}  // namespace aqs
