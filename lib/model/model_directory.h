#ifndef AQS_MODEL_MODEL_DIRECTORY_H_
#define AQS_MODEL_MODEL_DIRECTORY_H_

#include <ostream>
#include <string>
#include <vector>

#include "util/path_lock.h"

namespace aqs {

// The model directory as the unit that writers replace (docs/model_format.md,
// "Writing"): what may be replaced, the writers' lock, and the cleanup of what killed
// writers left.

// The path writers replace for the model at `dir`: trailing slashes removed, and a
// symbolic link resolved (the link's target is replaced, not the link).
std::string ResolveModelPath(const std::string& dir);

// The format version in <dir>/model.txt (its "format N" line), or 0 if `dir` is not an
// ActiveQS model (no readable model.txt with such a line).
int ModelFormatVersion(const std::string& dir);

// Whether a model may be written at `path`: a missing path, an empty directory and an
// ActiveQS model (ModelFormatVersion > 0) holding only files of the model format may be
// replaced; anything else (another directory, a file, a model with other files in it,
// which the replacement would delete) only with `overwrite`. Returns false with *error
// naming `path` (and the foreign files).
bool CheckModelDestination(const std::string& path, bool overwrite, std::string* error);

// Whether the learned state of the model at `dir` (learned/) may be replaced: it holds
// only files of the model format. Returns false with *error naming the others.
bool CheckLearnedStateDestination(const std::string& dir, std::string* error);

// Takes the writers' lock of the model at `dir` (util/path_lock.h: the lock file
// "<dir>.aqs-lock" beside it; the parent folder must exist). Taken afresh by this
// process, it also cleans up what killed writers left (CleanModelLeftovers), one line
// per action on `log` (or the INFO log if null). Returns false with *error "model DIR is
// in use by process PID (lock file F)" if another process holds it.
bool LockModelForWriting(const std::string& dir, std::ostream* log, PathLock* lock,
                         std::string* error);

// Removes or recovers, holding the lock, what writers killed while writing `dir` left:
//   - beside it, the staging and moved-aside directories of util/staged_directory.h
//     ("DIR.aqs-tmp<pid>", "DIR.aqs-old<pid>", identity file model.txt); a missing model
//     is recovered from a moved-aside one;
//   - beside it, "DIR.old<pid>" and "DIR.tmp<pid>" of ActiveQS before format 2: a
//     missing model is recovered (renamed back) from "DIR.old<pid>"; the others are
//     reported and kept (the names are not distinctive enough to delete);
//   - inside it, the learned state's staging directories ("learned.aqs-tmp<pid>", ...)
//     and temporary files "<name>.tmp<pid>" of util/atomic_file.h, where <name> is a
//     file of the model format (model.txt, decoder.txt, states/0003.bin, train/log.csv,
//     pretrain/surface_errors.bin, ...).
// Only leftovers of processes that are gone (or carry this process's pid) are touched.
// One line per action (or kept leftover) goes to *actions. Returns false with *error if
// a removal or rename failed.
bool CleanModelLeftovers(const std::string& dir, std::vector<std::string>* actions,
                         std::string* error);

}  // namespace aqs

#endif  // AQS_MODEL_MODEL_DIRECTORY_H_
