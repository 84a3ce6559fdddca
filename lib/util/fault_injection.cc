#include "util/fault_injection.h"

namespace aqs {
namespace {

FaultHook g_hook = nullptr;
FailureHook g_failure_hook = nullptr;

}  // namespace

FaultHook SetFaultHookForTesting(FaultHook hook) {
  FaultHook previous = g_hook;
  g_hook = hook;
  return previous;
}

void FaultPoint(const char* point) {
  if (g_hook != nullptr) g_hook(point);
}

FailureHook SetFailureHookForTesting(FailureHook hook) {
  FailureHook previous = g_failure_hook;
  g_failure_hook = hook;
  return previous;
}

bool FailurePoint(const char* point) {
  return g_failure_hook != nullptr && g_failure_hook(point);
}

}  // namespace aqs
