#include "util/path_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>

namespace aqs {
namespace {

namespace fs = std::filesystem;

constexpr char kHeader[] = "ActiveQS writer lock\n";

// The locks this process holds: lock file -> descriptor, count of PathLocks, and the
// pid that took it (a forked child finds its parent's entries and ignores them).
struct HeldLock {
  int fd = -1;
  int count = 0;
  pid_t owner = 0;
};

std::mutex& RegistryMutex() {
  static std::mutex mutex;
  return mutex;
}

std::map<std::string, HeldLock>& Registry() {
  static auto* registry = new std::map<std::string, HeldLock>();
  return *registry;
}

std::string ReadSmallFile(int fd) {
  char buffer[256];
  const ssize_t n = ::pread(fd, buffer, sizeof(buffer) - 1, 0);
  return n > 0 ? std::string(buffer, static_cast<size_t>(n)) : std::string();
}

// The pid named by a lock file's content ("" if none).
std::string HolderPid(const std::string& content) {
  const size_t at = content.find("pid ");
  if (at == std::string::npos) return "";
  std::string pid;
  for (size_t i = at + 4; i < content.size() && content[i] >= '0' && content[i] <= '9'; ++i) {
    pid += content[i];
  }
  return pid;
}

std::string Errno(int code) { return std::strerror(code); }

}  // namespace

std::string PathLock::LockFileOf(const std::string& path) {
  std::error_code code;
  fs::path p = fs::absolute(fs::path(path.empty() ? "." : path), code).lexically_normal();
  if (p.filename().empty() && p.has_parent_path() && p != p.root_path()) p = p.parent_path();
  const fs::path resolved = fs::weakly_canonical(p, code);
  if (!code) p = resolved;
  return p.string() + ".aqs-lock";
}

bool PathLock::Acquire(const std::string& path, std::string* error, const std::string& what) {
  Release();
  const std::string file = LockFileOf(path);
  std::lock_guard<std::mutex> guard(RegistryMutex());
  auto& registry = Registry();
  auto found = registry.find(file);
  if (found != registry.end()) {
    if (found->second.owner == ::getpid()) {
      ++found->second.count;
      lock_file_ = file;
      first_ = false;
      return true;
    }
    // Inherited from the parent through fork(): the lock is the parent's.
    ::close(found->second.fd);
    registry.erase(found);
  }
  for (int attempt = 0; attempt < 20; ++attempt) {
    const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      *error = "cannot create the lock file " + file + " (" + Errno(errno) + ")";
      return false;
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int code = errno;
      const std::string pid = HolderPid(ReadSmallFile(fd));
      ::close(fd);
      if (code == EWOULDBLOCK) {
        *error = (what.empty() ? path : what) + " is in use by " + (pid.empty() ? "another process" : "process " + pid) +
                 " (lock file " + file + ")";
      } else {
        *error = "cannot lock " + file + " (" + Errno(code) + ")";
      }
      return false;
    }
    // The file may have been removed (released) between open and flock: then the lock
    // is on a file nobody else will look at; start over.
    struct stat opened, named;
    if (::fstat(fd, &opened) != 0 || ::stat(file.c_str(), &named) != 0 ||
        opened.st_dev != named.st_dev || opened.st_ino != named.st_ino) {
      ::close(fd);
      continue;
    }
    const std::string content = ReadSmallFile(fd);
    if (!content.empty() && content.rfind(kHeader, 0) != 0) {
      ::close(fd);
      *error = file + " exists and is not an ActiveQS lock file (remove it or write elsewhere)";
      return false;
    }
    const std::string mine =
        std::string(kHeader) + "pid " + std::to_string(static_cast<long>(::getpid())) + "\n";
    if (::ftruncate(fd, 0) != 0 ||
        ::pwrite(fd, mine.data(), mine.size(), 0) != static_cast<ssize_t>(mine.size())) {
      const int code = errno;
      ::unlink(file.c_str());
      ::close(fd);
      *error = "cannot write the lock file " + file + " (" + Errno(code) + ")";
      return false;
    }
    registry[file] = HeldLock{fd, 1, ::getpid()};
    lock_file_ = file;
    first_ = true;
    return true;
  }
  *error = "cannot lock " + file + " (it keeps being replaced)";
  return false;
}

void PathLock::Release() {
  if (lock_file_.empty()) return;
  std::lock_guard<std::mutex> guard(RegistryMutex());
  auto& registry = Registry();
  auto found = registry.find(lock_file_);
  if (found != registry.end() && found->second.owner == ::getpid() && --found->second.count == 0) {
    // Unlinked while still locked: a process that opened it meanwhile finds, once it has
    // the lock, that the name points elsewhere, and starts over.
    ::unlink(lock_file_.c_str());
    ::close(found->second.fd);
    registry.erase(found);
  }
  lock_file_.clear();
  first_ = false;
}

}  // namespace aqs
