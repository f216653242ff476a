// The audit trail in the store, on both engines: a write made while an AuditScope lives records
// one row with its actor and change, in its own transaction, so a write that fails leaves none;
// writes without a scope, on other threads, or notifications between programs record nothing;
// the trail reads back newest first, in pages.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <thread>

#include "each_backend.hpp"
#include "skinspec/store/store.hpp"
#include "skinspec/testkit/postgres_cluster.hpp"
#include "skinspec/testkit/raw_database.hpp"
#include "skinspec/testkit/store_samples.hpp"

namespace skinspec {
namespace {

using namespace skinspec::store;
using ::testing::ElementsAre;
using ::testing::Field;
using testing::sample_session;
using testing::value_of;

const Actor kAna{"ana", "192.0.2.7", "POST /api/v1/sessions"};

class StoreAuditTest : public ::testing::TestWithParam<Backend> {
 protected:
  StoreAuditTest()
      : path_(GetParam() == Backend::sqlite
                  ? dir_.file("skinspec.db")
                  : testing::postgres_cluster().uri(testing::postgres_cluster().create_database())),
        store_(value_of(Store::open(path_))),
        raw_(testing::raw_database(path_)) {}

  long long audit_rows() { return raw_->integer("SELECT count(*) FROM audit"); }

  testing::ScratchDirectory dir_;
  std::string path_;
  Store store_;
  std::unique_ptr<testing::RawDatabase> raw_;
};

INSTANTIATE_TEST_SUITE_P(EachBackend, StoreAuditTest, ::testing::Values(Backend::sqlite, Backend::postgresql),
                         testing::backend_name);

TEST_P(StoreAuditTest, AWriteInAScopeRecordsItsActorAndChangeOnce) {
  Id session = 0;
  {
    AuditScope scope(kAna);
    session = value_of(store_.create_session(sample_session(1)));
  }
  const auto trail = value_of(store_.audit(std::nullopt, 10));
  ASSERT_EQ(trail.size(), 1u);
  EXPECT_EQ(trail[0].token, "ana");
  EXPECT_EQ(trail[0].address, "192.0.2.7");
  EXPECT_EQ(trail[0].request, "POST /api/v1/sessions");
  EXPECT_EQ(trail[0].change, "creating a session");
  EXPECT_GT(trail[0].at.time_since_epoch().count(), 0);
  EXPECT_EQ(value_of(store_.session(session)).subject, sample_session(1).subject);
}

// The audit row is in the change's transaction: a refused write leaves no row, as it leaves no
// change; and a change whose row cannot be written (the table gone) is not made either.
TEST_P(StoreAuditTest, AChangeAndItsAuditRowAreOneTransaction) {
  {
    AuditScope scope(kAna);
    EXPECT_FALSE(store_.update_job(12345, {JobState::running}));
  }
  EXPECT_EQ(audit_rows(), 0);

  raw_->execute("ALTER TABLE audit RENAME TO audit_gone");
  {
    AuditScope scope(kAna);
    EXPECT_FALSE(store_.create_session(sample_session(1)));
  }
  EXPECT_EQ(raw_->integer("SELECT count(*) FROM sessions"), 0);
  raw_->execute("ALTER TABLE audit_gone RENAME TO audit");
  {
    AuditScope scope(kAna);
    value_of(store_.create_session(sample_session(1)));
  }
  EXPECT_EQ(raw_->integer("SELECT count(*) FROM sessions"), 1);
  EXPECT_EQ(audit_rows(), 1);
}

TEST_P(StoreAuditTest, WritesWithoutAScopeOnAnotherThreadOrBetweenProgramsRecordNothing) {
  value_of(store_.create_session(sample_session(1)));
  AuditScope scope(kAna);
  std::thread([&] { value_of(store_.create_session(sample_session(2))); }).join();
  ASSERT_TRUE(store_.notify("skinspec_jobs", "bench-a"));
  EXPECT_EQ(audit_rows(), 0);
}

TEST_P(StoreAuditTest, TheTrailReadsBackNewestFirstInPages) {
  for (int n = 1; n <= 5; ++n) {
    AuditScope scope({"ana", "192.0.2.7", "POST /api/v1/sessions #" + std::to_string(n)});
    value_of(store_.create_session(sample_session(n)));
  }
  const auto first = value_of(store_.audit(std::nullopt, 2));
  ASSERT_EQ(first.size(), 2u);
  EXPECT_EQ(first[0].request, "POST /api/v1/sessions #5");
  EXPECT_EQ(first[1].request, "POST /api/v1/sessions #4");
  const auto rest = value_of(store_.audit(first[1].id, 10));
  EXPECT_THAT(rest, ElementsAre(Field(&AuditEntry::request, "POST /api/v1/sessions #3"),
                                Field(&AuditEntry::request, "POST /api/v1/sessions #2"),
                                Field(&AuditEntry::request, "POST /api/v1/sessions #1")));
  EXPECT_FALSE(store_.audit(std::nullopt, 0));
}

}  // namespace
}  // namespace skinspec
