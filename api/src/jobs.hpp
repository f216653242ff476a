#pragma once
// The events of one job (GET /api/v1/jobs/{id}/events): a Server-Sent Event `job` with the job
// as JSON for each change of its position, phase, progress or state, the last one when it
// has ended, after which the stream ends.

#include <atomic>

#include <nlohmann/json.hpp>

#include "skinspec/api/acquisition.hpp"
#include "skinspec/api/router.hpp"

namespace skinspec::api {

class JobEvents final : public EventSource {
 public:
  JobEvents(const store::Store& db, const JobWatch* watch, store::Id job_id);
  std::optional<std::string> next(std::chrono::milliseconds keep_alive) override;
  void close() override;

 private:
  const store::Store& db_;
  const JobWatch* watch_;  // what runs the job; null: the job as stored, once
  const store::Id job_id_;
  std::atomic<bool> closed_{false};
  bool ended_ = false;
  std::uint64_t sequence_ = 0;  // the events' ids
  nlohmann::json sent_;         // the job as last sent
};

}  // namespace skinspec::api
