#include "util/fault_injection.h"

namespace aqs {
namespace {

FaultHook g_hook = nullptr;

}  // namespace

FaultHook SetFaultHookForTesting(FaultHook hook) {
  FaultHook previous = g_hook;
  g_hook = hook;
  return previous;
}

void FaultPoint(const char* point) {
  if (g_hook != nullptr) g_hook(point);
}

}  // namespace aqs
