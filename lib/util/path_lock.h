#ifndef AQS_UTIL_PATH_LOCK_H_
#define AQS_UTIL_PATH_LOCK_H_

#include <string>

namespace aqs {

// An exclusive lock on a path for the processes that write it (advisory: writers take
// it, readers need not). It is flock(LOCK_EX | LOCK_NB) on the lock file
// "<path>.aqs-lock" beside `path` (beside, not inside, so that the lock outlives `path`
// being replaced by a rename), which holds the holder's pid for the refusal message:
//
//   ActiveQS writer lock
//   pid 12345
//
// The lock file is removed on release. One left by a killed process is taken over (a
// flock lock ends with its process). A file of that name that is not an ActiveQS lock
// file is never overwritten: Acquire fails naming it.
//
// Within one process the lock is shared: Acquire of a path this process holds already
// succeeds at once (an app holds its model's lock while the library calls it makes
// take it again); the lock is released when the last PathLock of the path releases it.
// A forked child does not inherit its parent's locks.
class PathLock {
 public:
  PathLock() = default;
  ~PathLock() { Release(); }
  PathLock(const PathLock&) = delete;
  PathLock& operator=(const PathLock&) = delete;

  // Takes the lock of `path` (which need not exist; its parent must). Returns false with
  // *error "<what> is in use by process <pid> (lock file <file>)" when another process
  // holds it (`what` defaults to the path), or saying why the lock file cannot be made
  // or used.
  bool Acquire(const std::string& path, std::string* error, const std::string& what = "");
  // Releases the lock (no-op when not held).
  void Release();

  bool held() const { return !lock_file_.empty(); }
  // True if the last Acquire took the lock afresh, i.e. no other PathLock of this
  // process held it: the holder may clean up what killed writers left.
  bool first() const { return first_; }

  // The lock file of `path`: its absolute, normalized form (symbolic links resolved)
  // followed by ".aqs-lock".
  static std::string LockFileOf(const std::string& path);

 private:
  std::string lock_file_;
  bool first_ = false;
};

}  // namespace aqs

#endif  // AQS_UTIL_PATH_LOCK_H_
