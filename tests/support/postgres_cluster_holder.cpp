// Starts a throwaway PostgreSQL cluster, prints "directory DIR" and "server PID", and waits
// until it is killed: postgres_cluster_test kills it to see the guardian clean up after it.

#include <unistd.h>

#include <cstdio>
#include <exception>

#include "skinspec/testkit/postgres_cluster.hpp"

int main() {
  try {
    skinspec::testing::PostgresCluster cluster;
    std::printf("directory %s\nserver %d\n", cluster.directory().c_str(), static_cast<int>(cluster.server_pid()));
    std::fflush(stdout);
    for (;;) ::pause();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "postgres_cluster_holder: %s\n", e.what());
    return 1;
  }
}
