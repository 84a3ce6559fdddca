// The program whose precompiled header every test program reuses (tests/CMakeLists.txt,
// AQS_PRECOMPILED_HEADERS). It does nothing; only its compile flags matter.
int main() { return 0; }
