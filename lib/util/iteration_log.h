#ifndef AQS_UTIL_ITERATION_LOG_H_
#define AQS_UTIL_ITERATION_LOG_H_

#include <string>

namespace aqs {

// CSV logs of iterative work that resumes from checkpoints (training's train/log.csv,
// pre-training's pretrain/run_log.csv): a header line, then one row per iteration whose
// first field is the iteration number and whose every field is a finite number.

// Whether `line` is a whole row for `header` (its number of fields, each a finite
// number): a run killed while appending leaves a partial row.
bool IsWholeLogRow(const std::string& line, const std::string& header);

// Prepares the log at `path` for a run that continues after `iteration` iterations:
// keeps the header and the whole rows of iterations 0..iteration, in increasing order,
// once each (a killed run may have logged further than it saved, or left a partial
// row), or holds the header alone when `iteration` is 0 (a new run logs its row 0).
// `header` ends with a newline. Replaced atomically. *last_row is the last iteration
// kept (-1: none): less than `iteration` if the log was cut or replaced apart from what
// it records; *last_line (may be null) that row's text ("" for none). Returns false with
// *error if it cannot be written.
bool PrepareIterationLog(const std::string& path, const std::string& header, int iteration,
                         int* last_row, std::string* error, std::string* last_line = nullptr);

// Appends `row` (one line, with its newline) to the log at `path` and flushes it (a log
// is appended row by row, not replaced: a kill may leave a partial last row, which
// PrepareIterationLog drops; an append after such a part first cuts the part off, since
// a part cut in its last field can look whole, with a wrong number).
// False with *error naming the path and the reason if it could not be opened or written
// (a full disk, a removed folder).
bool AppendLogRow(const std::string& path, const std::string& row, std::string* error);

}  // namespace aqs

#endif  // AQS_UTIL_ITERATION_LOG_H_
