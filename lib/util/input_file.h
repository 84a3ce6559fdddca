#ifndef AQS_UTIL_INPUT_FILE_H_
#define AQS_UTIL_INPUT_FILE_H_

#include <string>
#include <vector>

namespace aqs {

// The longest line the text readers accept (LineReader, the PLY header and ASCII data):
// 1 MiB. Every ActiveQS text format has short lines (a mesh record, a latent of a few
// hundred numbers); a longer line is a broken or foreign file, and reading it whole
// would cost about 23 times its length once split into tokens.
constexpr long long kMaxLineBytes = 1LL << 20;

// Checks that `path` names a regular file that can be read (symbolic links are
// followed), before it is opened: a FIFO would block the reader forever, and a device
// such as /dev/zero or /dev/urandom never ends. Returns false with *error naming the
// path and what it is instead ("is a directory", "is a FIFO (named pipe)", "is a
// character device", "does not exist", ...).
bool CheckInputFile(const std::string& path, std::string* error);

// Whether `path` exists, or its status cannot be read (no permission to search a folder
// on the way, a name too long, ...), so that the caller's reading of it then says why.
// False only where it surely does not exist. Never throws (std::filesystem::exists(path)
// throws std::filesystem::filesystem_error in the second case, which nothing catches).
bool MayExist(const std::string& path);

// Checks that a file can be written at `path` before a job's work: its folder exists
// and is a writable directory, and `path` is not a directory. Returns false with
// *error naming the path and why ("the folder F does not exist", ...). Outputs are
// written atomically (util/atomic_file.h) into that folder at the end.
bool CheckOutputFile(const std::string& path, std::string* error);

// Checks that the output `output` (a file or a folder) leaves the input `input` alone:
// if `input` is a folder (a model directory, a test set, a sequence's folder), `output`
// must not be it or lie inside it (a model directory holds its own files only, and a
// foreign file makes it unloadable); if `input` is a file, `output` must not be that file
// (symbolic links and "." and ".." resolved). Empty paths pass. Returns false with
// *error naming both.
bool CheckOutputApart(const std::string& output, const std::string& input, std::string* error);

// Checks that no two of a job's outputs (empty paths skipped) are one file (symbolic
// links and "." and ".." resolved): the last written would replace the other. Returns
// false with *error naming the path ("PATH: given for two outputs; ...").
bool CheckOutputsDistinct(const std::vector<std::string>& outputs, std::string* error);

// Checks that the input `input` (a file or a folder) is neither the folder `replaced`,
// which a job empties and writes anew, nor inside it (symbolic links and "." and ".."
// resolved). Empty paths pass. Returns false with *error naming both.
bool CheckInputOutside(const std::string& input, const std::string& replaced,
                       std::string* error);

}  // namespace aqs

#endif  // AQS_UTIL_INPUT_FILE_H_
