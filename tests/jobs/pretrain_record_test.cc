// The pre-training record's stall line and how a kept record compares with a run's
// (jobs/pretrain_record.h).
#include "jobs/pretrain_record.h"

#include <string>

#include <gtest/gtest.h>

namespace aqs {
namespace {

const char kRecord[] = "key model 0123456789abcdef\nbudget 500 0\nsimulated 1\n";

TEST(PretrainRecordTest, AStallWithFewerRestartsThanAllowedCouldGoFurther) {
  const std::string record = kRecord;
  int stalled = 0;
  // The same record; an older version's stalled pre-training has no stall line.
  EXPECT_EQ(MatchPretrainRecord(record, record, 50, &stalled), PretrainRecordMatch::kSame);
  EXPECT_EQ(stalled, -1);
  // Stalled with 0 restarts: 50 could take it further; 0 could not.
  const std::string with_stall = record + PretrainStallLine(0);
  EXPECT_EQ(with_stall, record + "stalled_restarts 0\n");
  EXPECT_EQ(MatchPretrainRecord(with_stall, record, 50, &stalled),
            PretrainRecordMatch::kCouldGoFurther);
  EXPECT_EQ(stalled, 0);
  EXPECT_EQ(MatchPretrainRecord(with_stall, record, 0, &stalled), PretrainRecordMatch::kSame);
  EXPECT_EQ(MatchPretrainRecord(record + PretrainStallLine(50), record, 50, &stalled),
            PretrainRecordMatch::kSame);
  EXPECT_EQ(stalled, 50);
  // Another budget, another key, no record, a malformed stall line.
  EXPECT_EQ(MatchPretrainRecord(with_stall, "key model 0123456789abcdef\nbudget 900 0\n"
                                            "simulated 1\n", 50, &stalled),
            PretrainRecordMatch::kOther);
  EXPECT_EQ(MatchPretrainRecord("", record, 50, &stalled), PretrainRecordMatch::kOther);
  for (const char* bad : {"stalled_restarts x\n", "stalled_restarts -1\n", "stalled_restarts 1"}) {
    EXPECT_EQ(MatchPretrainRecord(record + bad, record, 50, &stalled),
              PretrainRecordMatch::kOther) << bad;
  }
}

}  // namespace
}  // namespace aqs
