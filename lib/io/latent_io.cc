#include "io/latent_io.h"

#include <sstream>

#include <Eigen/LU>

#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/number_format.h"
#include "util/finite_values.h"

namespace aqs {

bool WriteLatentFile(const std::string& path, const Eigen::VectorXd& latent,
                     const std::vector<std::string>& bone_names,
                     const std::vector<RigidTransform>& bones, const std::string& comment,
                     const LatentFileModel& origin, std::string* error) {
  if (!AllFiniteForWriting(path, latent.transpose(), "latent entry", error)) return false;
  for (size_t b = 0; b < bones.size(); ++b) {
    Eigen::Matrix<double, 3, 4> bone;
    bone << bones[b].rotation, bones[b].translation;
    if (!AllFiniteForWriting(path, bone, "bone " + std::to_string(b) + " column", error)) {
      return false;
    }
  }
  std::string text = "# ActiveQS latent file";
  if (!comment.empty()) text += ": " + comment;
  text += "\nlatent";
  for (Eigen::Index i = 0; i < latent.size(); ++i) {
    text += ' ';
    AppendDouble(latent[i], &text);
  }
  text += '\n';
  for (size_t b = 0; b < bones.size() && b < bone_names.size(); ++b) {
    text += "bone " + bone_names[b];
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        text += ' ';
        AppendDouble(bones[b].rotation(r, c), &text);
      }
    }
    for (int c = 0; c < 3; ++c) {
      text += ' ';
      AppendDouble(bones[b].translation[c], &text);
    }
    text += '\n';
  }
  if (!origin.model.empty()) text += "model " + origin.model + " " + origin.learned + "\n";
  return WriteFileAtomically(path, text, error);
}

bool ReadLatentFile(const std::string& path, int latent_dim,
                    const std::vector<std::string>& bone_names, Eigen::VectorXd* latent,
                    std::vector<RigidTransform>* bones, LatentFileModel* origin,
                    std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  Eigen::VectorXd z;
  std::vector<RigidTransform> transforms(bone_names.size());
  std::vector<std::string> t;
  bool have_latent = false, have_model = false;
  LatentFileModel model;
  std::vector<bool> have_bone(bone_names.size(), false);
  while (reader.NextTokens(&t)) {
    if (t[0] == "latent") {
      if (have_latent) {
        *error = reader.Where("a second 'latent' line (a latent file holds one)");
        return false;
      }
      if (static_cast<int>(t.size()) != latent_dim + 1) {
        std::ostringstream out;
        out << "expected " << latent_dim << " latent numbers (the model's latent dimension), got "
            << t.size() - 1;
        *error = reader.Where(out.str());
        return false;
      }
      z.resize(latent_dim);
      for (int i = 0; i < latent_dim; ++i) {
        if (!ParseDouble(t[1 + i], &z[i])) {
          *error = reader.Where("expected a number, got " + Quoted(t[1 + i]));
          return false;
        }
      }
      have_latent = true;
    } else if (t[0] == "bone") {
      if (t.size() != 14) {
        *error = reader.Where("expected 'bone <name>' and 12 numbers (rotation row by row, translation)");
        return false;
      }
      int b = -1;
      for (size_t i = 0; i < bone_names.size(); ++i) {
        if (bone_names[i] == t[1]) b = static_cast<int>(i);
      }
      if (b < 0) {
        *error = reader.Where("the model has no bone named '" + t[1] + "'");
        return false;
      }
      if (have_bone[b]) {
        *error = reader.Where("bone '" + t[1] + "' is given a second time");
        return false;
      }
      have_bone[b] = true;
      RigidTransform transform;
      for (int i = 0; i < 12; ++i) {
        double v = 0;
        if (!ParseDouble(t[2 + i], &v)) {
          *error = reader.Where("expected a number, got " + Quoted(t[2 + i]));
          return false;
        }
        if (i < 9) {
          transform.rotation(i / 3, i % 3) = v;
        } else {
          transform.translation[i - 9] = v;
        }
      }
      const Eigen::Matrix3d& r = transform.rotation;
      if ((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
          std::abs(r.determinant() - 1.0) > 1e-6) {
        *error = reader.Where("the rotation of bone '" + t[1] + "' is not a proper rotation");
        return false;
      }
      transforms[b] = transform;
    } else if (t[0] == "model") {
      auto is_fingerprint = [](const std::string& text) {
        return text.size() == 16 &&
               text.find_first_not_of("0123456789abcdef") == std::string::npos;
      };
      if (have_model) {
        *error = reader.Where("a second 'model' line");
        return false;
      }
      if (t.size() != 3 || !is_fingerprint(t[1]) || !is_fingerprint(t[2])) {
        *error = reader.Where("expected 'model' and two fingerprints of 16 hexadecimal digits "
                              "(the model's and its learned state's)");
        return false;
      }
      model.model = t[1];
      model.learned = t[2];
      have_model = true;
    } else {
      *error = reader.Where("expected a 'latent', 'bone' or 'model' line, got " + Quoted(t[0]));
      return false;
    }
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (!have_latent) {
    *error = path + ": no 'latent' line";
    return false;
  }
  *latent = z;
  *bones = transforms;
  if (origin != nullptr) *origin = model;
  return true;
}

}  // namespace aqs
