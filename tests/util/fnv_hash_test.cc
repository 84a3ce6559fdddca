#include "util/fnv_hash.h"

#include <cstring>

#include <gtest/gtest.h>

namespace aqs {
namespace {

// FNV-1a's mixing: from FNV's standard offset basis the published values come out
// (the empty input, "a", "foobar"); hashing in pieces equals hashing at once.
TEST(FnvHashTest, IsFnv1aAndContinues) {
  constexpr uint64_t kStandardBasis = 14695981039346656037ull;
  EXPECT_EQ(Fnv1a("", 0, kStandardBasis), 0xcbf29ce484222325ull);
  EXPECT_EQ(Fnv1a("a", 1, kStandardBasis), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(Fnv1a("foobar", 6, kStandardBasis), 0x85944171f73967e8ull);
  const char* text = "shape targeting";
  const size_t n = std::strlen(text);
  EXPECT_EQ(Fnv1a(text + 5, n - 5, Fnv1a(text, 5, kFnvOffsetBasis)),
            Fnv1a(text, n, kFnvOffsetBasis));
  EXPECT_NE(Fnv1a("ab", 2, kFnvOffsetBasis), Fnv1a("ba", 2, kFnvOffsetBasis));
}

}  // namespace
}  // namespace aqs
