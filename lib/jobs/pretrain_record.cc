#include "jobs/pretrain_record.h"

#include "util/line_reader.h"
#include "util/number_format.h"

namespace aqs {
namespace {

constexpr char kStallWord[] = "stalled_restarts ";

}  // namespace

std::string PretrainRecord(const PretrainOptions& options, const ActiveModel& model,
                           bool simulated) {
  std::string text;
  for (const auto& [name, value] : PretrainCheckpointKey(options, model)) {
    text += "key " + name + " " + value + "\n";
  }
  return text + "budget " + std::to_string(options.max_iterations) + " " +
         FormatDouble(options.max_seconds) + "\nsimulated " + std::to_string(simulated) + "\n";
}

std::string PretrainStallLine(int max_restarts) {
  return kStallWord + std::to_string(max_restarts) + "\n";
}

PretrainRecordMatch MatchPretrainRecord(const std::string& kept, const std::string& record,
                                        int max_restarts, int* stalled_restarts) {
  *stalled_restarts = -1;
  if (kept.empty()) return PretrainRecordMatch::kOther;
  std::string base = kept;
  const size_t line_start = base.rfind('\n', base.size() >= 2 ? base.size() - 2 : 0);
  const size_t last = line_start == std::string::npos ? 0 : line_start + 1;
  const size_t word = sizeof(kStallWord) - 1;
  if (base.compare(last, word, kStallWord) == 0 && base.back() == '\n') {
    long long restarts = -1;
    const std::string number = base.substr(last + word, base.size() - 1 - last - word);
    if (!ParseInt64(number, &restarts) || restarts < 0 || restarts > 1000000000LL) {
      return PretrainRecordMatch::kOther;
    }
    *stalled_restarts = static_cast<int>(restarts);
    base.erase(last);
  }
  if (base != record) return PretrainRecordMatch::kOther;
  return *stalled_restarts >= 0 && *stalled_restarts < max_restarts
             ? PretrainRecordMatch::kCouldGoFurther
             : PretrainRecordMatch::kSame;
}

}  // namespace aqs
