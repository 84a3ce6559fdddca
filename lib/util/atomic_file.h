#ifndef AQS_UTIL_ATOMIC_FILE_H_
#define AQS_UTIL_ATOMIC_FILE_H_

#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

namespace aqs {

// Writes a file atomically: the content goes to a temporary file next to `path`
// ("<path>.tmp<pid>"), which is flushed to disk (fsync) and replaces `path` (rename) only
// on Commit(). An early return or any failure leaves an existing `path` untouched and
// removes the temporary file; a killed process leaves `path` old or new and at most the
// temporary file, which the model writers remove later (model/model_directory.h).
//
//   AtomicFileWriter writer(path);
//   writer.stream() << ...;
//   if (!writer.Commit(&error)) ...
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(const std::string& path);
  ~AtomicFileWriter();
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  // False if the temporary file could not be created (Commit then fails with why).
  bool ok() const { return static_cast<bool>(stream_); }
  std::ostream& stream() { return stream_; }
  // Flushes, closes and renames into place. Returns false with *error on failure.
  bool Commit(std::string* error);

 private:
  std::string path_;
  std::string temp_path_;
  std::ofstream stream_;
  bool committed_ = false;
};

// Writes `content` to `path` atomically. Returns false with *error on failure.
bool WriteFileAtomically(const std::string& path, const std::string& content,
                         std::string* error);

// The largest file ReadWholeFile reads (its records and logs are kilobytes).
inline constexpr std::uintmax_t kMaxWholeFileBytes = std::uintmax_t{256} << 20;

// The text of the file at `path` ("" if it cannot be read, is not a regular file (a
// FIFO, a device) or is larger than kMaxWholeFileBytes): what WriteFileAtomically
// wrote, for records compared whole (store keys, pre-training's record).
std::string ReadWholeFile(const std::string& path);

// Removes from the folder `dir` (not its subfolders) the temporary files
// "<name>.tmp<pid>" that killed writers left, for the names `is_output` accepts: those of
// processes that are gone, of this process's pid (which, under the folder's lock, can
// only be a dead predecessor's), or of a process that started after the file was last
// written (a reused pid). Call it only while holding the folder's writers' lock.
// Appends one line per file to *removed: "removed PATH, left by process PID", or "kept
// PATH: ..." for one of a process that runs and may have written it.
// Returns false with *error if one cannot be removed; a folder that cannot be listed is
// left as it is.
bool RemoveStaleTemporaryFiles(const std::string& dir,
                               const std::function<bool(const std::string& name)>& is_output,
                               std::vector<std::string>* actions, std::string* error);

// Flushes the folder `dir`'s entries to the disk (fsync of the folder), so that renames
// and new entries in it survive a crash of the machine, not only of the process. Best
// effort: a folder that cannot be opened is left as it is.
void SyncDirectory(const std::string& dir);

// Flushes the file `path`'s data to the disk (fsync), for a file written by other means
// than WriteFileAtomically (a copy). False with *error naming it.
bool SyncFile(const std::string& path, std::string* error);

// SyncDirectory of `dir` and of every folder under it.
void SyncDirectoryTree(const std::string& dir);

}  // namespace aqs

#endif  // AQS_UTIL_ATOMIC_FILE_H_
