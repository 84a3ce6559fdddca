#ifndef AQS_TESTING_SANITIZERS_H_
#define AQS_TESTING_SANITIZERS_H_

namespace aqs {
namespace testing {

// True when this program was compiled with AddressSanitizer or ThreadSanitizer
// (-DAQS_SANITIZE=...). Their runtimes replace malloc (glibc's mallinfo2 and mallopt
// no longer describe the heap) and reserve terabytes of address space for shadow memory
// (so a limit on the address space stops them): the few tests of those two things skip
// themselves there, saying why.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kSanitizedAllocator = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
inline constexpr bool kSanitizedAllocator = true;
#else
inline constexpr bool kSanitizedAllocator = false;
#endif
#else
inline constexpr bool kSanitizedAllocator = false;
#endif

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_SANITIZERS_H_
