#ifndef AQS_JOBS_PRETRAIN_RECORD_H_
#define AQS_JOBS_PRETRAIN_RECORD_H_

#include <string>

#include "model/active_model.h"
#include "train/pretrain.h"

namespace aqs {

// The record of a finished pre-training (pretrain/key.txt, learning_jobs.h), whole-file
// text: one "key NAME VALUE" line per entry of PretrainCheckpointKey (the model, the
// targets, every option that shapes the decoder), "budget MAX_ITERATIONS MAX_SECONDS"
// and "simulated 0|1" (whether the poses were simulated after it).
std::string PretrainRecord(const PretrainOptions& options, const ActiveModel& model,
                           bool simulated);

// The line a record ends with where the pre-training stopped where L-BFGS stalled before
// its budget with all of its `max_restarts` restarts used
// (PretrainReport::stalled_without_restarts): "stalled_restarts R".
std::string PretrainStallLine(int max_restarts);

// How a kept record compares with this run's (`record`, without a stall line), for a
// run that allows `max_restarts` restarts.
enum class PretrainRecordMatch {
  kSame,            // the same pre-training: nothing left to do
  kCouldGoFurther,  // the same, but it stalled with fewer restarts than now allowed
  kOther,           // another pre-training, none recorded, or an unreadable record
};
// *stalled_restarts: the kept record's stall line's restarts (-1 without one). Records
// written before the stall line existed (2026-12-06) have none: a pre-training of theirs
// that stalled compares as kSame, its unused budget unspent.
PretrainRecordMatch MatchPretrainRecord(const std::string& kept, const std::string& record,
                                        int max_restarts, int* stalled_restarts);

}  // namespace aqs

#endif  // AQS_JOBS_PRETRAIN_RECORD_H_
