#include "util/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "util/fault_injection.h"
#include "util/staged_directory.h"

namespace aqs {
namespace {

// Flushes the file's data to the disk (so that a crash of the machine after the rename
// cannot leave an empty or partial file under the final name). Returns errno or 0.
int SyncFile(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return errno;
  const int result = ::fsync(fd) == 0 ? 0 : errno;
  ::close(fd);
  return result;
}

}  // namespace

AtomicFileWriter::AtomicFileWriter(const std::string& path)
    : path_(path),
      temp_path_(path + ".tmp" + std::to_string(static_cast<long>(::getpid()))),
      stream_(temp_path_, std::ios::out | std::ios::trunc | std::ios::binary) {}

AtomicFileWriter::~AtomicFileWriter() {
  if (!committed_) {
    stream_.close();
    std::remove(temp_path_.c_str());
  }
}

bool AtomicFileWriter::Commit(std::string* error) {
  if (!stream_.is_open()) {
    *error = path_ + ": cannot create temporary file " + temp_path_ + " (" +
             std::strerror(errno) + ")";
    return false;
  }
  stream_.flush();
  const bool write_ok = static_cast<bool>(stream_);
  stream_.close();
  if (!write_ok || stream_.fail()) {
    *error = path_ + ": write failed (disk full or I/O error)";
    std::remove(temp_path_.c_str());
    committed_ = true;
    return false;
  }
  if (const int code = SyncFile(temp_path_); code != 0) {
    *error = path_ + ": cannot flush " + temp_path_ + " to disk (" + std::strerror(code) + ")";
    std::remove(temp_path_.c_str());
    committed_ = true;
    return false;
  }
  FaultPoint("atomic_file:written");
  if (std::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    *error = path_ + ": cannot move temporary file into place (" + std::strerror(errno) + ")";
    std::remove(temp_path_.c_str());
    committed_ = true;
    return false;
  }
  committed_ = true;
  // The rename itself is an entry of the folder: flushed too, or a crash of the machine
  // could bring back the old file (or none).
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  SyncDirectory(parent.empty() ? "." : parent.string());
  FaultPoint("atomic_file:renamed");
  return true;
}

bool WriteFileAtomically(const std::string& path, const std::string& content,
                         std::string* error) {
  AtomicFileWriter writer(path);
  writer.stream().write(content.data(), static_cast<std::streamsize>(content.size()));
  return writer.Commit(error);
}

std::string ReadWholeFile(const std::string& path) {
  // Only a regular file of bounded size: a FIFO put in its place would block the reader
  // forever (holding its job's lock), and a link to a device such as /dev/zero would be
  // read until memory ran out.
  std::error_code code;
  if (!std::filesystem::is_regular_file(path, code)) return "";
  const std::uintmax_t size = std::filesystem::file_size(path, code);
  if (code || size > kMaxWholeFileBytes) return "";
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

bool RemoveStaleTemporaryFiles(const std::string& dir,
                               const std::function<bool(const std::string& name)>& is_output,
                               std::vector<std::string>* actions, std::string* error) {
  std::error_code code;
  for (const std::filesystem::directory_entry& entry :
       std::filesystem::directory_iterator(dir, code)) {
    if (!entry.is_regular_file(code) || entry.is_symlink(code)) continue;
    const std::string name = entry.path().filename().string();
    const size_t at = name.rfind(".tmp");
    if (at == std::string::npos || at == 0 || !is_output(name.substr(0, at))) continue;
    const long pid = WriterPidOf(name, name.substr(0, at), ".tmp");
    if (pid < 0) continue;
    const bool gone = pid == static_cast<long>(::getpid()) || ProcessIsGone(pid);
    const bool reused = !gone && ProcessStartedAfterWrite(pid, entry.path().string());
    if (!gone && !reused) {
      actions->push_back("kept " + entry.path().string() + ": named like a temporary file of "
                         "process " + std::to_string(pid) + ", which runs; remove it if no "
                         "ActiveQS process writes into " + dir);
      continue;
    }
    if (::unlink(entry.path().c_str()) != 0 && errno != ENOENT) {
      *error = "cannot remove " + entry.path().string() + " (" + std::strerror(errno) + ")";
      return false;
    }
    actions->push_back("removed " + entry.path().string() + ", left by process " +
                       std::to_string(pid) +
                       (reused ? " (its pid now names a process started after it was written)"
                               : ""));
  }
  return true;
}

void SyncDirectory(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

bool SyncFile(const std::string& path, std::string* error) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 || ::fsync(fd) != 0) {
    *error = path + ": cannot flush to the disk (" + std::strerror(errno) + ")";
    if (fd >= 0) ::close(fd);
    return false;
  }
  ::close(fd);
  return true;
}

void SyncDirectoryTree(const std::string& dir) {
  std::error_code code;
  for (std::filesystem::recursive_directory_iterator it(dir, code), end; !code && it != end;
       it.increment(code)) {
    if (it->is_directory(code) && !it->is_symlink(code)) SyncDirectory(it->path().string());
  }
  SyncDirectory(dir);
}

}  // namespace aqs
