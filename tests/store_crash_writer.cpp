// Helper for the crash-safety test: writes measurement-plus-fit transactions to the database
// given as its argument until it is killed, printing each one's ids only after its commit has
// returned. Lines:
//   session <session id> job <job id>
//   committed <measurement id> <fit id> <n>     (n: the sample number, see store_samples.hpp)

#include <cstdio>

#include "skinspec/store/store.hpp"
#include "support/store_samples.hpp"

using namespace skinspec::store;

namespace {

template <typename T>
T must(Result<T> result, const char* what) {
  if (!result) {
    std::fprintf(stderr, "store_crash_writer: %s: %s\n", what, result.error().message.c_str());
    std::exit(1);
  }
  return std::move(*result);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: store_crash_writer DATABASE\n");
    return 2;
  }
  auto store = must(Store::open(argv[1]), "open");
  const Id session = must(store.create_session(skinspec::testing::sample_session(1)), "session");
  Job job;
  job.kind = "measure";
  job.session_id = session;
  const Id job_id = must(store.create_job(job), "job").job.id;
  must(store.update_job(job_id, {.state = JobState::running}), "job start");
  std::printf("session %lld job %lld\n", static_cast<long long>(session), static_cast<long long>(job_id));
  std::fflush(stdout);
  for (int n = 0;; ++n) {
    auto m = skinspec::testing::sample_measurement(session, n);
    m.job_id = job_id;
    const auto ids = must(store.record_measurement(m, skinspec::testing::sample_fit(n)), "record");
    std::printf("committed %lld %lld %d\n", static_cast<long long>(ids.measurement_id),
                static_cast<long long>(*ids.fit_id), n);
    std::fflush(stdout);
  }
}
