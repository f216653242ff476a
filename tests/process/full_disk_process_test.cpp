// skinspecd with its store on a small tmpfs of its own (a private mount namespace, as root,
// which CI is), the disk filled while an import is stored: the job fails with code storage_full,
// nothing of the file is stored, reads go on, and once space is freed the same import succeeds
// without a restart. The store is a SQLite file, or a PostgreSQL cluster whose whole data
// directory (its WAL too) is on the tmpfs.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <optional>

#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <sstream>

#include "skinspec/client/http_client.hpp"
#include "skinspec/testkit/acquisition_rig.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
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

// A daemon whose store is on a small disk of its own, and the means to fill that disk.
class OnASmallDisk : public ::testing::Test {
 protected:
  static constexpr const char* kRootOnly = "mounting a tmpfs of its own needs root (CI runs as root)";

  // skinspecd on `db`, started by `program` with `args` (so that it can be started inside a
  // mount namespace).
  void start_daemon(const std::string& program, const std::vector<std::string>& args) {
    daemon_ = std::make_unique<BackgroundProcess>(program, args);
    const auto line = daemon_->wait_for_stdout_line("skinspecd listening on http://127.0.0.1:", 30s);
    ASSERT_TRUE(line) << daemon_->err();
    port_ = static_cast<unsigned short>(std::stoi(line->substr(line->rfind(':') + 1)));
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

  // The whole case: an import refused on a full disk, one that fills it as it is stored, and
  // the same import once there is room.
  void import_onto_a_full_disk() {
    const long long session = new_session(port_, "disk");
    ASSERT_GT(session, 0);
    ASSERT_EQ(import(session, spectra_file(3))["state"], "succeeded");
    fill_disk();
    const std::string big = spectra_file(1500);
    const auto on_a_full_disk = post_import(session, big);
    if (full_disk_refuses_the_jobs_record_) {
      // Not even the job's record can be written: the request is refused.
      EXPECT_EQ(on_a_full_disk.status, 507) << on_a_full_disk.body;
      EXPECT_EQ(on_a_full_disk.json()["error"]["code"], "storage_full") << on_a_full_disk.body;
    } else {
      // The record fits in a page its table already has; the spectra do not.
      ASSERT_EQ(on_a_full_disk.status, 202) << on_a_full_disk.body;
      const json failed = wait_for_job(port_, on_a_full_disk.json(), 120s);
      EXPECT_EQ(failed["state"], "failed") << failed.dump(2);
      EXPECT_EQ(failed["error"]["code"], "storage_full") << failed.dump(2);
    }
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

  ScratchDirectory disk_;
  fs::path disk_seen_;  // the disk's root as this process reaches it
  // SQLite must grow its file for any write; PostgreSQL has room left in its tables' pages.
  bool full_disk_refuses_the_jobs_record_ = true;
  std::unique_ptr<BackgroundProcess> daemon_;
  unsigned short port_ = 0;
};

// SQLite: the daemon alone in a mount namespace of its own (`unshare -m`), its file on a 16 MB
// tmpfs there.
class FullDiskTest : public OnASmallDisk {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << kRootOnly;
    const std::string script =
        "mount -t tmpfs -o size=16m tmpfs \"$0\" && exec \"$1\" --db \"$0/lab.db\" --listen 127.0.0.1:0 "
        "--log-level warn";
    start_daemon("/usr/bin/unshare", {"-m", "--propagation", "private", "sh", "-c", script, disk_.path().string(),
                                      SKINSPEC_TEST_BIN_DIR "/skinspecd"});
    // The tmpfs as the daemon sees it: through its process's root, in its mount namespace.
    disk_seen_ = fs::path(fmt::format("/proc/{}/root", daemon_->pid())) / disk_.path().relative_path();
    ASSERT_TRUE(fs::exists(disk_seen_ / "lab.db")) << "the store is not on the daemon's tmpfs";
  }
};

// PostgreSQL: this test process (one test per process, under ctest) moves into a mount namespace
// of its own and mounts a 96 MB tmpfs there; the cluster it starts, data directory and WAL, is on
// it, and the daemon connects to it through its socket.
class FullDiskPostgresTest : public OnASmallDisk {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << kRootOnly;
    ASSERT_EQ(::unshare(CLONE_NEWNS), 0) << std::strerror(errno);
    ASSERT_EQ(::mount("none", "/", nullptr, MS_REC | MS_PRIVATE, nullptr), 0) << std::strerror(errno);
    ASSERT_EQ(::mount("tmpfs", disk_.path().c_str(), "tmpfs", 0, "size=96m,mode=0755"), 0) << std::strerror(errno);
    mounted_ = true;
    disk_seen_ = disk_.path();
    full_disk_refuses_the_jobs_record_ = false;
    ClusterSettings settings;
    settings.base = disk_.path();
    cluster_.emplace(settings);
    ASSERT_TRUE(cluster_->directory().string().starts_with(disk_.path().string()));
    const std::string uri = cluster_->uri(cluster_->create_database("full"));
    start_daemon(SKINSPEC_TEST_BIN_DIR "/skinspecd", {"--db", uri, "--listen", "127.0.0.1:0", "--log-level", "warn"});
  }
  void TearDown() override {
    daemon_.reset();
    cluster_.reset();
    if (mounted_) ::umount2(disk_.path().c_str(), MNT_DETACH);
  }

  std::optional<PostgresCluster> cluster_;
  bool mounted_ = false;
};

TEST_F(FullDiskTest, AnImportOntoAFullDiskFailsAsStorageFullAndSucceedsOnceThereIsSpace) { import_onto_a_full_disk(); }

TEST_F(FullDiskPostgresTest, AnImportOntoAFullDiskFailsAsStorageFullAndSucceedsOnceThereIsSpace) {
  import_onto_a_full_disk();
  if (HasFailure()) ADD_FAILURE() << "the server's log:\n" << cluster_->log_tail();
}

}  // namespace
}  // namespace skinspec::testing
