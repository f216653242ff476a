// The program that owns the suites' precompiled GoogleTest headers (tests/CMakeLists.txt).
int main() { return 0; }
