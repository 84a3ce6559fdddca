#include "util/staged_directory.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "util/atomic_file.h"
#include "util/fault_injection.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

bool g_disable_exchange = false;

std::string Errno(int code) { return std::strerror(code); }

std::string WithoutTrailingSlashes(std::string path) {
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  return path;
}

std::string ParentOf(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? "." : parent.string();
}

// Swaps two existing paths in one step; returns 0 or errno.
int Exchange(const std::string& a, const std::string& b) {
  if (g_disable_exchange) return EINVAL;
#ifdef RENAME_EXCHANGE
  return ::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0 ? 0 : errno;
#else
  return ENOSYS;
#endif
}

enum class PathKind { kMissing, kEmptyDirectory, kOther };

PathKind Classify(const std::string& path) {
  std::error_code code;
  const fs::file_status status = fs::symlink_status(path, code);
  if (code || !fs::exists(status)) return PathKind::kMissing;
  if (fs::is_directory(status) && fs::is_empty(path, code) && !code) {
    return PathKind::kEmptyDirectory;
  }
  return PathKind::kOther;
}

bool Exists(const std::string& path) {
  std::error_code code;
  return fs::exists(fs::symlink_status(path, code));
}

bool WriteMarker(const std::string& dir, std::string* error) {
  const std::string marker = dir + "/" + kTemporaryMarker;
  const int fd = ::open(marker.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    *error = "cannot create " + marker + " (" + Errno(errno) + ")";
    return false;
  }
  ::close(fd);
  return true;
}

// A directory this library made as a temporary: it holds the marker, the unit's
// identity file, or nothing.
bool RecognizedTemporary(const std::string& dir, const std::string& identity_file) {
  std::error_code code;
  if (!fs::is_directory(fs::symlink_status(dir, code))) return false;
  if (Exists(dir + "/" + kTemporaryMarker)) return true;
  if (!identity_file.empty() && Exists(dir + "/" + identity_file)) return true;
  return fs::is_empty(dir, code) && !code;
}

// "<base>.aqs-<kind><digits>" -> pid; -1 if `name` is not such a name.
long LeftoverPid(const std::string& name, const std::string& base, const std::string& kind) {
  const std::string prefix = base + ".aqs-" + kind;
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return -1;
  long pid = 0;
  for (size_t i = prefix.size(); i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9' || pid > 1000000000L) return -1;
    pid = 10 * pid + (name[i] - '0');
  }
  return pid;
}

}  // namespace

std::string MovedAsideOf(const std::string& target_in) {
  const std::string target = WithoutTrailingSlashes(target_in);
  const std::string base = fs::path(target).filename().string();
  std::error_code code;
  for (const fs::directory_entry& entry : fs::directory_iterator(ParentOf(target), code)) {
    if (LeftoverPid(entry.path().filename().string(), base, "old") >= 0) {
      return entry.path().string();
    }
  }
  return "";
}

std::string StagingPathOf(const std::string& target) {
  return WithoutTrailingSlashes(target) + ".aqs-tmp" + std::to_string(static_cast<long>(::getpid()));
}

long WriterPidOf(const std::string& name, const std::string& stem, const std::string& suffix) {
  const std::string prefix = stem + suffix;
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return -1;
  long pid = 0;
  for (size_t i = prefix.size(); i < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9' || pid > 1000000000L) return -1;
    pid = 10 * pid + (name[i] - '0');
  }
  return pid;
}

long StaleWriterPid(const std::string& name, const std::string& stem, const std::string& suffix) {
  const long pid = WriterPidOf(name, stem, suffix);
  if (pid < 0 || (pid != static_cast<long>(::getpid()) && !ProcessIsGone(pid))) return -1;
  return pid;
}

bool ProcessStartedAfterWrite(long pid, const std::string& path) {
  struct stat file;
  if (pid <= 0 || ::stat(path.c_str(), &file) != 0) return false;
  // Field 22 of /proc/PID/stat: the start in clock ticks after boot. The second field
  // (the command in parentheses) may hold spaces, so the fields count from its last ')'.
  std::FILE* stat_file = std::fopen(("/proc/" + std::to_string(pid) + "/stat").c_str(), "r");
  if (stat_file == nullptr) return false;
  char buffer[4096];
  const size_t size = std::fread(buffer, 1, sizeof(buffer) - 1, stat_file);
  std::fclose(stat_file);
  buffer[size] = '\0';
  const char* field = std::strrchr(buffer, ')');
  unsigned long long start_ticks = 0;
  for (int f = 2; field != nullptr && f < 22; ++f) field = std::strchr(field + 1, ' ');
  if (field == nullptr || std::sscanf(field, " %llu", &start_ticks) != 1) return false;
  std::FILE* boot_file = std::fopen("/proc/stat", "r");
  if (boot_file == nullptr) return false;
  char line[512];
  long long boot_seconds = -1;
  while (boot_seconds < 0 && std::fgets(line, sizeof(line), boot_file) != nullptr) {
    if (std::sscanf(line, "btime %lld", &boot_seconds) != 1) boot_seconds = -1;
  }
  std::fclose(boot_file);
  const long ticks_per_second = ::sysconf(_SC_CLK_TCK);
  if (boot_seconds < 0 || ticks_per_second <= 0) return false;
  const double started = static_cast<double>(boot_seconds) +
                         static_cast<double>(start_ticks) / static_cast<double>(ticks_per_second);
  const double modified =
      static_cast<double>(file.st_mtim.tv_sec) + 1e-9 * static_cast<double>(file.st_mtim.tv_nsec);
  return started > modified + 2.0;
}

bool ProcessIsGone(long pid) {
  if (pid <= 0) return false;
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

bool CreateStagingDirectory(const std::string& staging, std::string* error) {
  if (Exists(staging)) {
    if (!RecognizedTemporary(staging, "")) {
      *error = staging + " exists and is not an ActiveQS temporary directory";
      return false;
    }
    if (!RemoveTemporaryTree(staging, error)) return false;
  }
  if (::mkdir(staging.c_str(), 0755) != 0) {
    *error = "cannot create directory " + staging + " (" + Errno(errno) + ")";
    return false;
  }
  if (!WriteMarker(staging, error)) {
    ::rmdir(staging.c_str());
    return false;
  }
  FaultPoint("staging:created");
  return true;
}

bool InstallStagingDirectory(const std::string& staging, const std::string& target_in,
                             std::string* warning, std::string* error) {
  const std::string target = WithoutTrailingSlashes(target_in);
  const std::string parent = ParentOf(target);
  const std::string marker = staging + "/" + kTemporaryMarker;
  if (::unlink(marker.c_str()) != 0 && errno != ENOENT) {
    *error = "cannot remove " + marker + " (" + Errno(errno) + ")";
    return false;
  }
  SyncDirectoryTree(staging);  // its subfolders' entries too (poses/, learned/states/, ...)
  FaultPoint("staging:filled");
  if (Classify(target) != PathKind::kOther) {
    // Nothing to keep: rename(2) replaces a missing target or an empty directory.
    if (::rename(staging.c_str(), target.c_str()) != 0) {
      *error = "cannot move " + staging + " to " + target + " (" + Errno(errno) + ")";
      return false;
    }
    FaultPoint("staging:installed");
    SyncDirectory(parent);
    return true;
  }
  std::string displaced;
  const int code = Exchange(staging, target);
  if (code == 0) {
    displaced = staging;
    FaultPoint("staging:exchanged");
  } else if (code == EINVAL || code == ENOSYS || code == ENOTSUP || code == EOPNOTSUPP) {
    // No atomic exchange here: two renames, the old content kept under a name that
    // CleanLeftovers recovers from.
    displaced = target + ".aqs-old" + std::to_string(static_cast<long>(::getpid()));
    if (::rename(target.c_str(), displaced.c_str()) != 0) {
      *error = "cannot move " + target + " aside to " + displaced + " (" + Errno(errno) + ")";
      return false;
    }
    SyncDirectory(parent);
    FaultPoint("staging:moved_aside");
    if (::rename(staging.c_str(), target.c_str()) != 0) {
      *error = "cannot move " + staging + " to " + target + " (" + Errno(errno) + ")";
      ::rename(displaced.c_str(), target.c_str());
      return false;
    }
    FaultPoint("staging:installed");
  } else {
    *error = "cannot exchange " + staging + " and " + target + " (" + Errno(code) + ")";
    return false;
  }
  SyncDirectory(parent);
  std::string removal_error;
  if (!RemoveTemporaryTree(displaced, &removal_error)) {
    *warning = "could not remove the replaced content: " + removal_error;
  }
  return true;
}

bool RemoveTemporaryTree(const std::string& path, std::string* error) {
  std::error_code code;
  const fs::file_status status = fs::symlink_status(path, code);
  if (code || !fs::exists(status)) return true;
  if (!fs::is_directory(status)) {
    if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
      *error = "cannot remove " + path + " (" + Errno(errno) + ")";
      return false;
    }
    FaultPoint("remove:done");
    return true;
  }
  if (!WriteMarker(path, error)) return false;
  FaultPoint("remove:marked");
  for (const fs::directory_entry& entry : fs::directory_iterator(path, code)) {
    if (entry.path().filename() == kTemporaryMarker) continue;
    fs::remove_all(entry.path(), code);
    if (code) {
      *error = "cannot remove " + entry.path().string() + " (" + code.message() + ")";
      return false;
    }
    FaultPoint("remove:entry");
  }
  if (code) {
    *error = "cannot list " + path + " (" + code.message() + ")";
    return false;
  }
  const std::string marker = path + "/" + kTemporaryMarker;
  if (::unlink(marker.c_str()) != 0 || ::rmdir(path.c_str()) != 0) {
    *error = "cannot remove " + path + " (" + Errno(errno) + ")";
    return false;
  }
  FaultPoint("remove:done");
  return true;
}

bool CleanLeftovers(const std::string& target_in, const std::string& identity_file,
                    std::vector<std::string>* actions, std::string* error) {
  const std::string target = WithoutTrailingSlashes(target_in);
  const std::string parent = ParentOf(target);
  const std::string base = fs::path(target).filename().string();
  struct Leftover {
    std::string path;
    long pid;
    bool moved_aside;
    // A process of its pid is running. Under the target's lock it cannot be the writer
    // that left it (every writer holds the lock): the pid was reused.
    bool pid_running;
  };
  std::vector<Leftover> leftovers;
  std::error_code code;
  for (const fs::directory_entry& entry : fs::directory_iterator(parent, code)) {
    const std::string name = entry.path().filename().string();
    long pid = LeftoverPid(name, base, "tmp");
    const bool moved_aside = pid < 0;
    if (moved_aside) pid = LeftoverPid(name, base, "old");
    if (pid < 0) continue;
    const bool running = pid != static_cast<long>(::getpid()) && !ProcessIsGone(pid);
    leftovers.push_back({entry.path().string(), pid, moved_aside, running});
  }
  if (code) return true;  // no parent folder: nothing left over
  if (Classify(target) == PathKind::kMissing) {
    for (auto it = leftovers.begin(); it != leftovers.end(); ++it) {
      if (!it->moved_aside || identity_file.empty() ||
          !Exists(it->path + "/" + identity_file) || Exists(it->path + "/" + kTemporaryMarker)) {
        continue;
      }
      if (::rename(it->path.c_str(), target.c_str()) != 0) {
        *error = "cannot move " + it->path + " back to " + target + " (" + Errno(errno) + ")";
        return false;
      }
      SyncDirectory(parent);
      // Also when a process of its pid is running: the target is missing, and the old
      // content would otherwise be left beside a new one (s23 IO review F12).
      actions->push_back("recovered " + target + " from " + it->path + " (moved aside by process " +
                         std::to_string(it->pid) + ", which stopped before replacing it" +
                         (it->pid_running ? "; its pid is now another process's" : "") + ")");
      leftovers.erase(it);
      break;
    }
  }
  for (const Leftover& leftover : leftovers) {
    if (leftover.pid_running) {
      actions->push_back("kept " + leftover.path + ": named like a temporary of process " +
                         std::to_string(leftover.pid) +
                         ", which is running but does not hold the lock; remove it yourself "
                         "if it is not needed");
      continue;
    }
    if (!RecognizedTemporary(leftover.path, identity_file)) {
      actions->push_back("kept " + leftover.path + ": named like a temporary of process " +
                         std::to_string(leftover.pid) +
                         " but not recognized as one; remove it yourself if it is not needed");
      continue;
    }
    if (!RemoveTemporaryTree(leftover.path, error)) return false;
    actions->push_back("removed " + leftover.path + ", left by process " +
                       std::to_string(leftover.pid));
  }
  return true;
}

void DisableExchangeForTesting(bool disable) { g_disable_exchange = disable; }

}  // namespace aqs
