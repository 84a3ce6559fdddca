#ifndef AQS_UTIL_FAULT_INJECTION_H_
#define AQS_UTIL_FAULT_INJECTION_H_

namespace aqs {

// Test hook for multi-step writes (atomic files, model swaps, checkpoints): the writing
// code calls FaultPoint("name") between its steps, and a test can install a hook that
// stops the process there (raise(SIGKILL) in a forked child) to check that every
// intermediate state on disk is consistent. Without a hook FaultPoint does nothing.
// The hook is process-wide and not synchronized: install it before starting threads.
using FaultHook = void (*)(const char* point);

// Installs `hook` (nullptr: none) and returns the previous one.
FaultHook SetFaultHookForTesting(FaultHook hook);

// Calls the installed hook, if any, with `point` (a short static name such as
// "atomic_file:written").
void FaultPoint(const char* point);

// Test hook for failures that are hard to provoke (an optimizer's line search that finds
// no valid step): code that can fail at a step asks FailurePoint("name") and, where it
// returns true, fails there as it would on its own error. A test installs a hook that
// says when. Without a hook FailurePoint returns false. Process-wide and not
// synchronized, as the fault hook.
using FailureHook = bool (*)(const char* point);

// Installs `hook` (nullptr: none) and returns the previous one.
FailureHook SetFailureHookForTesting(FailureHook hook);

// The installed hook's answer for `point` (a short static name such as
// "autoencoder:evaluate"); false without a hook.
bool FailurePoint(const char* point);

}  // namespace aqs

#endif  // AQS_UTIL_FAULT_INJECTION_H_
