// limit_open_files N PROGRAM [ARG...]: runs PROGRAM (a path) with its soft limit on open files
// (RLIMIT_NOFILE) lowered to N, as `ulimit -n N` would. It execs, so PROGRAM keeps this
// process's id and a test can watch it as its own child.

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: limit_open_files N PROGRAM [ARG...]\n");
    return 2;
  }
  rlimit limit{};
  if (::getrlimit(RLIMIT_NOFILE, &limit) != 0) return std::perror("getrlimit"), 1;
  limit.rlim_cur = static_cast<rlim_t>(std::stoul(argv[1]));
  if (::setrlimit(RLIMIT_NOFILE, &limit) != 0) return std::perror("setrlimit"), 1;
  ::execv(argv[2], argv + 2);
  std::perror(argv[2]);
  return 127;
}
