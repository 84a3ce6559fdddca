#include "dist/model_broadcast.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "model/model_fingerprint.h"
#include "model/model_io.h"
#include "util/atomic_file.h"
#include "util/make_directory.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

// This rank's temporary folder (not created), or "" with *error.
std::string TemporaryFolder(int rank, std::string* error) {
  std::error_code code;
  const fs::path base = fs::temp_directory_path(code);
  if (code) {
    *error = "no temporary directory to pass the model between ranks (" + code.message() +
             "; set TMPDIR)";
    return "";
  }
  return (base / ("aqs-model-" + std::to_string(getpid()) + "-" + std::to_string(rank)))
      .string();
}

// Every file under `folder` as one text: per file "<path length> <size>\n", the path
// (relative to `folder`) and the bytes.
bool PackFolder(const std::string& folder, std::string* packed, std::string* error) {
  std::error_code code;
  std::ostringstream out;
  for (fs::recursive_directory_iterator it(folder, code), end; !code && it != end;
       it.increment(code)) {
    if (!it->is_regular_file(code)) continue;
    const std::string relative = fs::relative(it->path(), folder, code).string();
    std::ifstream in(it->path(), std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    if (!in && !in.eof()) {
      *error = it->path().string() + ": cannot read (passing the model between ranks)";
      return false;
    }
    const std::string content = bytes.str();
    out << relative.size() << " " << content.size() << "\n" << relative << content;
  }
  if (code) {
    *error = folder + ": cannot list (" + code.message() + ")";
    return false;
  }
  *packed = out.str();
  return true;
}

// The files of PackFolder's text written under `folder` (created).
bool UnpackFolder(const std::string& packed, const std::string& folder, std::string* error) {
  size_t at = 0;
  while (at < packed.size()) {
    const size_t line_end = packed.find('\n', at);
    size_t path_size = 0, content_size = 0;
    std::istringstream header(packed.substr(at, line_end - at));
    if (line_end == std::string::npos || !(header >> path_size >> content_size) ||
        line_end + 1 + path_size + content_size > packed.size()) {
      *error = "the model sent by rank 0 arrived damaged";
      return false;
    }
    const std::string relative = packed.substr(line_end + 1, path_size);
    const fs::path path = fs::path(folder) / relative;
    if (!MakeDirectory(path.parent_path().string(), error)) return false;
    std::ofstream out(path, std::ios::binary);
    out.write(packed.data() + line_end + 1 + path_size, static_cast<std::streamsize>(content_size));
    if (!out.flush()) {
      *error = path.string() + ": cannot write (passing the model between ranks)";
      return false;
    }
    at = line_end + 1 + path_size + content_size;
  }
  return true;
}

// What every rank must hold as rank 0 does: the model's fingerprint (ModelFingerprint)
// and that of its decoder and latents (not the states, nor the fit priors, which
// LoadModel learns where a model has none).
std::string Identity(const ActiveModel& model) {
  ActiveModel learned;
  learned.decoder = model.decoder;
  learned.decoder_params = model.decoder_params;
  learned.latents = model.latents;
  return FingerprintText(ModelFingerprint(model)) + " " +
         FingerprintText(LearnedStateFingerprint(learned));
}

}  // namespace

bool BroadcastModel(const Communicator& comm, ActiveModel* model, std::string* error) {
  if (comm.size() == 1) return true;
  std::string folder = TemporaryFolder(comm.rank(), error);
  bool ok = !folder.empty();
  std::string remove_error;
  if (ok) RemoveDirectory(folder, &remove_error);  // a killed run's, of the same pid
  std::string packed;
  if (ok && comm.is_root()) {
    ok = SaveModel(folder + "/model", *model, error) &&
         PackFolder(folder + "/model", &packed, error);
    RemoveDirectory(folder, &remove_error);
  }
  if (!comm.Agree(ok, error)) return false;
  comm.BroadcastText(&packed, 0);
  if (!comm.is_root()) {
    ActiveModel received;
    ok = UnpackFolder(packed, folder + "/model", error) &&
         LoadModel(folder + "/model", &received, error);
    packed.clear();
    if (!folder.empty()) RemoveDirectory(folder, &remove_error);
    if (ok) *model = std::move(received);
  }
  if (!comm.Agree(ok, error)) return false;
  // The same model everywhere: rank 0's fingerprints on every rank.
  const std::string own = Identity(*model);
  std::string root = own;
  comm.BroadcastText(&root, 0);
  if (own != root) {
    *error = "the model sent by rank 0 (fingerprints " + root + ") was loaded as another (" +
             own + ")";
  }
  return comm.Agree(own == root, error);
}

}  // namespace aqs
