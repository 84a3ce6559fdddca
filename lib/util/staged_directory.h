#ifndef AQS_UTIL_STAGED_DIRECTORY_H_
#define AQS_UTIL_STAGED_DIRECTORY_H_

#include <string>
#include <vector>

namespace aqs {

// Replacing a directory as one unit: the new content is written into a staging
// directory beside the target, which then takes the target's place, so that a process
// killed at any moment leaves the old or the new content at the target, and leftovers
// that the next writer (holding the target's util/path_lock.h lock) recognizes as its
// own and removes or recovers. Names, beside a target T:
//
//   T.aqs-tmp<pid>   staging directory of process pid; after an exchange, the old content
//                    on its way out
//   T.aqs-old<pid>   the old content moved aside, only on file systems without
//                    RENAME_EXCHANGE, for the moment between two renames
//
// A temporary directory holds the marker file ".aqs-temporary" while it is being filled
// and while it is being removed (so that a half-filled or half-removed one is recognized).

constexpr char kTemporaryMarker[] = ".aqs-temporary";

// "<target>.aqs-tmp<pid of this process>".
std::string StagingPathOf(const std::string& target);

// Creates `staging` (removing a recognized leftover of the same name first) with the
// marker inside. Returns false with *error.
bool CreateStagingDirectory(const std::string& staging, std::string* error);

// Puts the filled directory `staging` at `target` and removes what was there:
//   - target missing or an empty directory: rename(2);
//   - anything else: renameat2(RENAME_EXCHANGE) swaps the two in one step, then the old
//     content, now at `staging`, is removed (RemoveTemporaryTree);
//   - where the file system cannot exchange: the old content is renamed to
//     "<target>.aqs-old<pid>" and `staging` to `target`; a kill in between leaves no
//     target, and CleanLeftovers renames the old content back.
// The marker is removed from `staging` before it goes into place, and the parent folder
// is synced. Returns false with *error, with the target untouched, if the content could
// not be put in place; a failure to remove the old content is only reported in
// *warning (it is a recognized leftover).
bool InstallStagingDirectory(const std::string& staging, const std::string& target,
                             std::string* warning, std::string* error);

// Removes a file, or a directory tree after writing the marker into it, removing the
// marker last: a kill midway leaves a recognized leftover. Does not follow symbolic
// links. Returns false with *error.
bool RemoveTemporaryTree(const std::string& path, std::string* error);

// True if no process `pid` exists (kill(pid, 0) fails with ESRCH).
bool ProcessIsGone(long pid);

// True if process `pid` runs and started more than 2 s after the file at `path` was last
// modified, so that it cannot have written it (its pid was reused, as after a reboot):
// the start from /proc/PID/stat and the boot time in /proc/stat. False where either is
// unknown.
bool ProcessStartedAfterWrite(long pid, const std::string& path);

// The pid digits of `name` = "<stem><suffix><pid digits>" (e.g. "frames.csv.tmp4242");
// -1 for any other name.
long WriterPidOf(const std::string& name, const std::string& stem, const std::string& suffix);

// The pid of a killed writer's leftover `name` = "<stem><suffix><pid digits>" (e.g.
// "frames.csv.tmp4242"), where that process is gone or is this one (which, under the
// folder's lock, can only be a dead predecessor's); -1 for any other name.
long StaleWriterPid(const std::string& name, const std::string& stem, const std::string& suffix);

// A "T.aqs-old<pid>" beside `target` (its old content, moved aside by a writer without
// an atomic exchange: one writing now, or one killed between its two renames), or ""
// if there is none. For readers, which take no lock.
std::string MovedAsideOf(const std::string& target);

// Cleans up what killed writers left beside `target` (the names above): when `target`
// is missing and a moved-aside "T.aqs-old<pid>" holds `identity_file` (a complete old
// version), it is renamed back to `target`, whatever runs under that pid now (under the
// lock no writer of the target is running: a running process of that pid has it by
// reuse). Other leftovers of processes that are gone, or of this process's pid (at lock
// time a dead predecessor's), are removed if they hold the marker, `identity_file`, or
// nothing; the rest, and those of running processes, are kept and reported. Call it
// only while holding the target's lock. Each action (or kept leftover) is described by
// one line in *actions. Returns false with *error if a removal or rename failed.
bool CleanLeftovers(const std::string& target, const std::string& identity_file,
                    std::vector<std::string>* actions, std::string* error);

// Tests only: behave as if the file system could not exchange two paths (exercises the
// two-rename fallback).
void DisableExchangeForTesting(bool disable);

}  // namespace aqs

#endif  // AQS_UTIL_STAGED_DIRECTORY_H_
