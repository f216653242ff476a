// The instrument connection's parts in-process: the backoff schedule, the choice of a meter or
// adapter for `auto`, the ports listing, the supervisor following a USB adapter or meter that
// comes back under another tty name (a resolver standing in for discovery maps it to one of two
// simulators), and its answer when the store refuses a job.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <mutex>
#include <thread>

#include "fitter_loader.hpp"
#include "instrument_link.hpp"
#include "reconnect.hpp"
#include "supervisor.hpp"
#include "support/service_processes.hpp"

namespace skinspec::daemon {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using std::chrono::milliseconds;

TEST(BackoffSchedule, RetriesAtOnceAfterALossThenDoublesUpToTheMaximum) {
  const BackoffPolicy policy{500ms, 30000ms};
  EXPECT_EQ(backoff_delay(policy, 0), 0ms);
  EXPECT_EQ(backoff_delay(policy, 1), 500ms);
  EXPECT_EQ(backoff_delay(policy, 2), 1000ms);
  EXPECT_EQ(backoff_delay(policy, 3), 2000ms);
  EXPECT_EQ(backoff_delay(policy, 6), 16000ms);
  EXPECT_EQ(backoff_delay(policy, 7), 30000ms);
  EXPECT_EQ(backoff_delay(policy, 1'000'000), 30000ms);
}

TEST(BackoffSchedule, AMaximumBelowTheInitialWaitIsTheInitialWait) {
  EXPECT_EQ(backoff_delay({800ms, 100ms}, 1), 800ms);
  EXPECT_EQ(backoff_delay({800ms, 100ms}, 5), 800ms);
}

drivers::PortInfo port(std::string path, std::optional<unsigned short> vid = {}, std::string serial = {},
                       unsigned short pid = 0x6001) {
  drivers::PortInfo p;
  p.path = std::move(path);
  p.kind = vid ? "usb" : "native";
  p.description = "a port";
  p.vendor_id = vid;
  p.product_id = vid ? std::optional<unsigned short>(pid) : std::nullopt;
  p.serial_number = std::move(serial);
  return p;
}

drivers::PortInfo meter(std::string path, std::string serial, unsigned short pid = 0x0524) {
  return port(std::move(path), 0x180b, std::move(serial), pid);
}

TEST(AutoDevice, IsTheFirstKnownAdapterInPathOrder) {
  const auto chosen =
      auto_device({port("/dev/ttyUSB1", 0x0403, "B"), port("/dev/ttyS0"), port("/dev/ttyUSB0", 0x067b, "A", 0x2303)});
  ASSERT_TRUE(chosen);
  EXPECT_EQ(chosen->path, "/dev/ttyUSB0");
  EXPECT_FALSE(auto_device({port("/dev/ttyS0"), port("/dev/ttyS1")}));
  EXPECT_FALSE(auto_device({}));
}

TEST(AutoDevice, PrefersAPhotoResearchMeterToAnAdapterWhateverThePaths) {
  const auto adapter = port("/dev/ttyUSB0", 0x0403, "FT1");
  const auto pr670 = meter("/dev/ttyACM3", "67012345");
  for (const auto& ports : {std::vector{adapter, pr670}, std::vector{pr670, adapter}}) {
    const auto chosen = auto_device(ports);
    ASSERT_TRUE(chosen);
    EXPECT_EQ(chosen->path, "/dev/ttyACM3");
  }
  const auto two = auto_device({meter("/dev/ttyACM1", "B"), adapter, meter("/dev/ttyACM0", "A")});
  ASSERT_TRUE(two);
  EXPECT_EQ(two->serial_number, "A");
}

// The order auto_device documents: 180b:0524, another 180b product, a known adapter, any other
// USB serial device; the paths are chosen against that order so that path order cannot pass.
TEST(AutoDevice, FollowsTheDocumentedOrder) {
  std::vector ports{port("/dev/ttyA", 0x2341, "arduino", 0x0043), port("/dev/ttyB", 0x10c4, "cp2102", 0xea60),
                    meter("/dev/ttyC", "unverified", 0x0525), meter("/dev/ttyD", "pr670")};
  for (const char* expected : {"/dev/ttyD", "/dev/ttyC", "/dev/ttyB", "/dev/ttyA"}) {
    const auto chosen = auto_device(ports);
    ASSERT_TRUE(chosen);
    EXPECT_EQ(chosen->path, expected);
    std::erase_if(ports, [&](const auto& p) { return p.path == chosen->path; });
  }
  EXPECT_FALSE(auto_device(ports));
}

TEST(PortsJson, GivesTheDeviceUriAndTheUsbIdentity) {
  const auto body = ports_json({port("/dev/ttyUSB0", 0x0403, "FT1"), port("/dev/ttyS0")});
  ASSERT_EQ(body["ports"].size(), 2u);
  EXPECT_EQ(body["ports"][0]["uri"], "usb:0403:6001:FT1");
  EXPECT_EQ(body["ports"][0]["name"], "/dev/ttyUSB0");
  EXPECT_EQ(body["ports"][0]["usb"]["vid"], "0403");
  EXPECT_EQ(body["ports"][0]["usb"]["pid"], "6001");
  EXPECT_EQ(body["ports"][0]["usb"]["serial"], "FT1");
  EXPECT_EQ(body["ports"][1]["uri"], "serial:/dev/ttyS0");
  EXPECT_EQ(body["ports"][1]["transport"], "native");
  EXPECT_TRUE(body["ports"][1]["usb"].is_null());
}

TEST(PortsJson, SaysWhichDeviceIsAMeterAndWhichAnAdapter) {
  const auto body = ports_json({meter("/dev/ttyACM0", "67012345"), port("/dev/ttyUSB0", 0x0403, "FT1"),
                                meter("/dev/ttyACM1", "", 0x0600), port("/dev/ttyUSB1", 0x2341, "", 0x0043)});
  ASSERT_EQ(body["ports"].size(), 4u);
  const auto& pr670 = body["ports"][0];
  EXPECT_EQ(pr670["uri"], "usb:180b:0524:67012345");
  EXPECT_EQ(pr670["usb"]["device_kind"], "photo-research-meter");
  EXPECT_EQ(pr670["usb"]["device_description"], "Photo Research meter");
  EXPECT_EQ(body["ports"][1]["usb"]["device_kind"], "rs232-adapter");
  EXPECT_EQ(body["ports"][1]["usb"]["device_description"], "FTDI FT232R RS-232 adapter");
  EXPECT_EQ(body["ports"][2]["usb"]["device_kind"], "photo-research-meter");
  EXPECT_THAT(body["ports"][2]["usb"]["device_description"].get<std::string>(), ::testing::HasSubstr("unverified"));
  EXPECT_EQ(body["ports"][2]["uri"], "usb:180b:0600");
  EXPECT_TRUE(body["ports"][3]["usb"]["device_kind"].is_null());
  EXPECT_TRUE(body["ports"][3]["usb"]["device_description"].is_null());
}

TEST(HotplugEvents, ConcernTheAdapterByIdentity) {
  const UsbIdentity adapter{0x0403, 0x6001, "FT1"};
  using K = drivers::UsbDeviceEvent::Kind;
  EXPECT_TRUE(concerns({K::detached, 0x0403, 0x6001, "FT1"}, adapter));
  EXPECT_TRUE(concerns({K::detached, 0x0403, 0x6001, ""}, adapter));  // serial unreadable
  EXPECT_FALSE(concerns({K::detached, 0x0403, 0x6001, "FT2"}, adapter));
  EXPECT_FALSE(concerns({K::detached, 0x067b, 0x6001, "FT1"}, adapter));
  EXPECT_TRUE(concerns({K::detached, 0x0403, 0x6001, "FT2"}, UsbIdentity{0x0403, 0x6001, ""}));
  const UsbIdentity pr670{0x180b, 0x0524, "67012345"};
  EXPECT_TRUE(concerns({K::detached, 0x180b, 0x0524, "67012345"}, pr670));
  EXPECT_FALSE(concerns({K::detached, 0x180b, 0x0524, "67099999"}, pr670));
  EXPECT_FALSE(concerns({K::detached, 0x0403, 0x6001, "67012345"}, pr670));
}

TEST(DeviceResolution, RefusesABadUriAndKeepsTcpAsItIs) {
  EXPECT_FALSE(resolve_device("bogus:thing"));
  const auto tcp = resolve_device("tcp:127.0.0.1:4001");
  ASSERT_TRUE(tcp) << tcp.error();
  EXPECT_EQ(tcp->uri.to_string(), "tcp:127.0.0.1:4001");
  EXPECT_FALSE(tcp->adapter);
  EXPECT_FALSE(resolve_device("usb:0403:6001:NO-SUCH-ADAPTER-HERE"));
}

// Where a fake USB device "is" today: a simulator's TCP port, or nowhere (0).
class FakeAdapterPlace {
 public:
  explicit FakeAdapterPlace(UsbIdentity identity) : identity_(std::move(identity)) {}
  void move_to(unsigned short port) {
    std::lock_guard lock(mutex_);
    port_ = port;
  }
  std::expected<ResolvedDevice, std::string> resolve(const std::string&) const {
    std::lock_guard lock(mutex_);
    if (port_ == 0) return std::unexpected("no such USB device");
    auto uri = drivers::parse_connection_uri("tcp:127.0.0.1:" + std::to_string(port_));
    return ResolvedDevice{*uri, identity_};
  }

 private:
  UsbIdentity identity_;
  mutable std::mutex mutex_;
  unsigned short port_ = 0;
};

json wait_for(const Supervisor& supervisor, const std::function<bool(const json&)>& done) {
  json status;
  for (int i = 0; i < 1500; ++i) {
    status = supervisor.instrument_status();
    if (done(status)) return status;
    std::this_thread::sleep_for(20ms);
  }
  return status;
}

std::string usb_uri(const UsbIdentity& identity) {
  return fmt::format("usb:{:04x}:{:04x}:{}", identity.vendor_id, identity.product_id, identity.serial_number);
}

struct UsbDeviceCase {
  const char* name;
  UsbIdentity identity;
};

void PrintTo(const UsbDeviceCase& device, std::ostream* out) { *out << usb_uri(device.identity); }

// An RS-232 adapter (a PR-650's cable) and a meter on its own USB port (180b:0524) alike.
class Hotplug : public ::testing::TestWithParam<UsbDeviceCase> {};

TEST_P(Hotplug, AUsbDeviceBackUnderANewTtyIsFollowed) {
  const UsbIdentity usb_device = GetParam().identity;
  testing::ScratchDirectory dir;
  auto first = testing::start_simulator(dir, "127.0.0.1:0");
  auto second = testing::start_simulator(dir, "127.0.0.1:0");
  ASSERT_TRUE(first.port != 0 && second.port != 0) << first.process->err() << second.process->err();
  auto db = store::Store::open(dir.file("lab.db"));
  ASSERT_TRUE(db) << db.error().message;
  auto fitter = load_fitter(SKINSPEC_TEST_DATA_DIR);
  ASSERT_TRUE(fitter) << fitter.error();

  FakeAdapterPlace place(usb_device);
  place.move_to(first.port);
  Supervisor supervisor(usb_uri(usb_device), *db, *fitter);
  Supervisor::ConnectionSettings settings;
  // Retries an hour apart and no idle checks: within this test only hot-plug events can make
  // the supervisor notice anything.
  settings.backoff = {std::chrono::hours(1), std::chrono::hours(1)};
  settings.check_interval = 0ms;
  settings.resolver = [&place](const std::string& device) { return place.resolve(device); };
  settings.hotplug = false;  // the test delivers the events
  supervisor.start_connection(settings);
  supervisor.start();

  auto status = wait_for(supervisor, [](const json& s) { return s["state"] == "connected"; });
  ASSERT_EQ(status["state"], "connected") << status;
  EXPECT_EQ(status["port"], "tcp:127.0.0.1:" + std::to_string(first.port));

  using K = drivers::UsbDeviceEvent::Kind;
  supervisor.on_usb_event({K::detached, usb_device.vendor_id, usb_device.product_id, "OTHER"});  // someone else's
  EXPECT_EQ(supervisor.instrument_status()["state"], "connected");

  place.move_to(0);
  supervisor.on_usb_event({K::detached, usb_device.vendor_id, usb_device.product_id, usb_device.serial_number});
  EXPECT_EQ(supervisor.instrument_status()["state"], "lost");
  // The attempt made at once fails (the adapter is nowhere); the next is an hour away.
  status = wait_for(supervisor, [](const json& s) { return s.value("attempts", 0) >= 1; });
  ASSERT_EQ(status["attempts"], 1) << status;
  EXPECT_EQ(status["state"], "lost") << status;

  place.move_to(second.port);
  supervisor.on_usb_event({K::attached, usb_device.vendor_id, usb_device.product_id, usb_device.serial_number});
  status = wait_for(supervisor, [](const json& s) { return s["state"] == "connected"; });
  EXPECT_EQ(status["state"], "connected") << status;
  EXPECT_EQ(status["port"], "tcp:127.0.0.1:" + std::to_string(second.port));
  supervisor.stop();
}

INSTANTIATE_TEST_SUITE_P(AdapterAndMeter, Hotplug,
                         ::testing::Values(UsbDeviceCase{"Adapter", {0x0403, 0x6001, "FT1"}},
                                           UsbDeviceCase{"Meter", {0x180b, 0x0524, "67012345"}}),
                         [](const auto& instance) { return std::string(instance.param.name); });

// The supervisor reports the store's refusals as every route does (api::from_store_error).
TEST(SupervisorJobs, TheStoresRefusalsAreTheServicesErrors) {
  testing::ScratchDirectory dir;
  store::Id session = 0;
  {
    auto db = store::Store::open(dir.file("lab.db"));
    ASSERT_TRUE(db) << db.error().message;
    store::Session s;
    s.subject = "S";
    s.site = "forearm";
    s.model = "extended";
    auto created = db->create_session(s);
    ASSERT_TRUE(created) << created.error().message;
    session = *created;
  }
  store::OpenOptions read_only;
  read_only.mode = store::OpenMode::read_only;
  auto db = store::Store::open(dir.file("lab.db"), read_only);
  ASSERT_TRUE(db) << db.error().message;
  auto fitter = load_fitter(SKINSPEC_TEST_DATA_DIR);
  ASSERT_TRUE(fitter) << fitter.error();
  Supervisor supervisor("tcp:127.0.0.1:1", *db, *fitter);

  const auto unknown = supervisor.submit(session + 1, {}, "");
  ASSERT_FALSE(unknown);
  EXPECT_EQ(api::http_status(unknown.error().kind), 404);
  EXPECT_EQ(unknown.error().code, "not_found");
  const auto refused = supervisor.submit(session, {}, "key-1");
  ASSERT_FALSE(refused);
  EXPECT_EQ(api::http_status(refused.error().kind), 503);
  EXPECT_EQ(refused.error().code, "database_read_only");
}

}  // namespace
}  // namespace skinspec::daemon
