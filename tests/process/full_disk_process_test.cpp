// skinspecd with its SQLite store on a small tmpfs of its own (a private mount namespace:
// `unshare -m`, as root, which CI is), the disk filled while an import is stored: the job fails
// with code storage_full, nothing of the file is stored, reads go on, and once space is freed
// the same import succeeds without a restart.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <sstream>

#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/process.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace skinspec::client;
using namespace std::chrono_literals;

// `rows` spectra, each the example's first under a name of its own.
std::string spectra_file(std::size_t rows) {
  std::ifstream in(std::string(SKINSPEC_TEST_DATA_DIR) + "/examples/import-rows-percent.csv");
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  const std::string values = row.substr(row.find(','));
  std::string out = header + "\n";
  for (std::size_t i = 0; i < rows; ++i) out += fmt::format("\"s{}\"{}\n", i, values);
  return out;
}

class FullDiskTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "mounting a tmpfs of its own needs root (CI runs as root)";
    const std::string script =
        "mount -t tmpfs -o size=16m tmpfs \"$0\" && exec \"$1\" --db \"$0/lab.db\" --listen 127.0.0.1:0 "
        "--log-level warn";
    daemon_ = std::make_unique<BackgroundProcess>(
        "/usr/bin/unshare", std::vector<std::string>{"-m", "--propagation", "private", "sh", "-c", script,
                                                     disk_.path().string(), SKINSPEC_TEST_BIN_DIR "/skinspecd"});
    const auto line = daemon_->wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", 30s);
    ASSERT_TRUE(line) << daemon_->err();
    port_ = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1)));
    // The tmpfs as the daemon sees it: through its process's root, in its mount namespace.
    disk_seen_ = fs::path(fmt::format("/proc/{}/root", daemon_->pid())) / disk_.path().relative_path();
    ASSERT_TRUE(fs::exists(disk_seen_ / "lab.db")) << "the store is not on the daemon's tmpfs";
  }
  // Writes a file until the disk is full.
  void fill_disk() {
    std::ofstream filler(disk_seen_ / "filler", std::ios::binary);
    const std::string block(1 << 16, 'x');
    while (filler.write(block.data(), static_cast<std::streamsize>(block.size())) && filler.flush()) {
    }
  }
  // Frees `bytes` of the filler.
  void free_disk(std::uintmax_t bytes) {
    const auto filler = disk_seen_ / "filler";
    fs::resize_file(filler, fs::file_size(filler) - bytes);
  }
  HttpReply post_import(long long session, const std::string& file) {
    return http_request(port_, "POST", fmt::format("/api/v1/sessions/{}/imports?name=big.csv", session), file,
                        {{"Content-Type", "text/csv"}});
  }
  json import(long long session, const std::string& file) {
    const auto reply = post_import(session, file);
    EXPECT_EQ(reply.status, 202) << reply.body;
    return wait_for_job(port_, reply.json(), 120s);
  }
  std::size_t measurements(long long session) {
    return get_json(port_, fmt::format("/api/v1/sessions/{}", session))["measurements"].size();
  }

  ScratchDirectory disk_;
  fs::path disk_seen_;
  std::unique_ptr<BackgroundProcess> daemon_;
  unsigned short port_ = 0;
};

TEST_F(FullDiskTest, AnImportOntoAFullDiskFailsAsStorageFullAndSucceedsOnceThereIsSpace) {
  const long long session = new_session(port_, "disk");
  ASSERT_GT(session, 0);
  ASSERT_EQ(import(session, spectra_file(3))["state"], "succeeded");
  fill_disk();
  // Not even the job's record can be written: the request is refused.
  const std::string big = spectra_file(1500);
  const auto refused = post_import(session, big);
  EXPECT_EQ(refused.status, 507) << refused.body;
  EXPECT_EQ(refused.json()["error"]["code"], "storage_full") << refused.body;
  // Room for the job's record, not for some 4 MB of spectra and their fits: the disk fills as
  // the import is stored.
  free_disk(256 << 10);
  const json failed = import(session, big);
  EXPECT_EQ(failed["state"], "failed") << failed.dump(2);
  EXPECT_EQ(failed["error"]["code"], "storage_full") << failed.dump(2);
  // Reads go on, and nothing of the file was stored.
  EXPECT_EQ(measurements(session), 3u);
  EXPECT_EQ(http_request(port_, "GET", "/healthz").status, 200);

  fs::remove(disk_seen_ / "filler");
  const json stored = import(session, big);
  EXPECT_EQ(stored["state"], "succeeded") << stored.dump(2);
  EXPECT_EQ(measurements(session), 1503u);
  EXPECT_FALSE(daemon_->has_exited()) << "the same daemon, never restarted";
}

}  // namespace
}  // namespace skinspec::testing
