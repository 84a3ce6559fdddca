#ifndef AQS_UTIL_ATOMIC_FILE_H_
#define AQS_UTIL_ATOMIC_FILE_H_

#include <fstream>
#include <string>

namespace aqs {

// Writes a file atomically: the content goes to a temporary file next to `path`, which
// replaces `path` (rename) only on Commit(). A crash or an early return leaves any
// existing `path` untouched and removes the temporary file.
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

}  // namespace aqs

#endif  // AQS_UTIL_ATOMIC_FILE_H_
