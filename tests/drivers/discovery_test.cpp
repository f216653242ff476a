// The known USB devices without hardware: the table and its classification as pure functions,
// the stable URI of a port, what `skinspec ports` prints for ports made up here (a meter, an
// adapter, an unknown USB device, a native port), and the udev rule read and applied to every
// row of the table as udev would match it (support/udev_rules.hpp).

#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <ranges>
#include <set>
#include <sstream>

#include "ports_format.hpp"
#include "skinspec/drivers/discovery.hpp"
#include "support/udev_rules.hpp"

namespace skinspec::drivers {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using testing::UdevDevice;
using testing::UdevEvent;
using testing::UdevOutcome;

// ---- The table ------------------------------------------------------------------------------

TEST(KnownUsbDevices, ThePhotoResearchMeterIsAMeter) {
  const auto pr670 = classify_usb_device(0x180b, 0x0524);
  ASSERT_TRUE(pr670);
  EXPECT_EQ(pr670->kind, UsbDeviceKind::photo_research_meter);
  EXPECT_EQ(pr670->product_id, 0x0524);
  EXPECT_EQ(pr670->description, "Photo Research meter");
  EXPECT_EQ(to_string(pr670->kind), "photo-research-meter");
}

TEST(KnownUsbDevices, TheCommonUsbSerialBridgesAreRs232Adapters) {
  for (const auto& [vid, pid] : std::vector<std::pair<unsigned short, unsigned short>>{{0x067b, 0x2303},
                                                                                       {0x0403, 0x6001},
                                                                                       {0x0403, 0x6014},
                                                                                       {0x0403, 0x6015},
                                                                                       {0x10c4, 0xea60},
                                                                                       {0x1a86, 0x7523},
                                                                                       {0x1a86, 0x5523}}) {
    const auto known = classify_usb_device(vid, pid);
    ASSERT_TRUE(known) << fmt::format("{:04x}:{:04x}", vid, pid);
    EXPECT_EQ(known->kind, UsbDeviceKind::rs232_adapter);
    EXPECT_EQ(known->product_id, pid);
    EXPECT_THAT(std::string(known->description), HasSubstr("RS-232 adapter"));
  }
  EXPECT_EQ(to_string(UsbDeviceKind::rs232_adapter), "rs232-adapter");
}

TEST(KnownUsbDevices, AnotherPhotoResearchProductIsAMeterMarkedUnverified) {
  const auto other = classify_usb_device(0x180b, 0x0525);
  ASSERT_TRUE(other);
  EXPECT_EQ(other->kind, UsbDeviceKind::photo_research_meter);
  EXPECT_FALSE(other->product_id);
  EXPECT_THAT(std::string(other->description), HasSubstr("unverified"));
}

TEST(KnownUsbDevices, OtherDevicesAreUnknown) {
  EXPECT_FALSE(classify_usb_device(0x2341, 0x0043));  // an Arduino
  EXPECT_FALSE(classify_usb_device(0x0403, 0x6010));  // an FTDI part not in the table
  EXPECT_FALSE(classify_usb_device(0x0524, 0x180b));  // the ids swapped
  EXPECT_FALSE(classify_usb_device(0, 0));
}

TEST(KnownUsbDevices, EachRowIsReachedByItsOwnIds) {
  std::set<std::pair<unsigned short, int>> seen;
  for (const auto& row : known_usb_devices()) {
    EXPECT_TRUE(seen.emplace(row.vendor_id, row.product_id.value_or(-1)).second) << row.description;
    EXPECT_FALSE(row.description.empty());
    if (!row.product_id) continue;
    const auto found = classify_usb_device(row.vendor_id, *row.product_id);
    ASSERT_TRUE(found);
    EXPECT_EQ(found->description, row.description);
  }
}

PortInfo usb_port(std::string path, unsigned short vid, unsigned short pid, std::string serial = {}) {
  PortInfo port;
  port.path = std::move(path);
  port.kind = "usb";
  port.description = "a USB serial port";
  port.vendor_id = vid;
  port.product_id = pid;
  port.serial_number = std::move(serial);
  return port;
}

PortInfo native_port(std::string path) {
  PortInfo port;
  port.path = std::move(path);
  port.kind = "native";
  port.description = "16550A";
  return port;
}

TEST(KnownUsbDevices, APortIsClassifiedByItsIds) {
  EXPECT_EQ(classify_port(usb_port("/dev/ttyACM0", 0x180b, 0x0524))->kind, UsbDeviceKind::photo_research_meter);
  EXPECT_EQ(classify_port(usb_port("/dev/ttyUSB0", 0x10c4, 0xea60))->kind, UsbDeviceKind::rs232_adapter);
  EXPECT_FALSE(classify_port(native_port("/dev/ttyS0")));
  auto half = usb_port("/dev/ttyACM1", 0x180b, 0x0524);
  half.product_id.reset();  // libserialport could not read the ids
  EXPECT_FALSE(classify_port(half));
}

TEST(StableUri, NamesAUsbDeviceByItsIdsAndOtherPortsByPath) {
  EXPECT_EQ(stable_uri(usb_port("/dev/ttyACM0", 0x180b, 0x0524, "67012345")), "usb:180b:0524:67012345");
  EXPECT_EQ(stable_uri(usb_port("/dev/ttyUSB3", 0x0403, 0x6001)), "usb:0403:6001");
  EXPECT_EQ(stable_uri(native_port("/dev/ttyS0")), "serial:/dev/ttyS0");
}

TEST(FindUsbPort, AnAbsentMeterIsNamedAsAMeter) {
  const auto found = find_usb_port(0x180b, 0x0524, "NO-SUCH-METER-42");
  ASSERT_FALSE(found);
  EXPECT_THAT(found.error(), HasSubstr("180b:0524 (Photo Research meter)"));
  EXPECT_THAT(found.error(), HasSubstr("NO-SUCH-METER-42"));
}

// ---- skinspec ports -----------------------------------------------------------------------------

std::vector<PortInfo> a_bench() {
  return {usb_port("/dev/ttyACM0", 0x180b, 0x0524, "67012345"), usb_port("/dev/ttyUSB0", 0x0403, 0x6001, "FT1"),
          usb_port("/dev/ttyUSB1", 0x2341, 0x0043), native_port("/dev/ttyS0")};
}

TEST(PortsFormat, JsonMarksTheMeterAndTheAdapter) {
  const auto ports = nlohmann::json::parse(cli::ports_json_line(a_bench()));
  ASSERT_TRUE(ports.is_array());
  ASSERT_EQ(ports.size(), 4u);
  const std::set<std::string> fields{
      "path", "kind",      "description", "serial_number", "manufacturer",      "product",
      "uri",  "vendor_id", "product_id",  "device_kind",   "device_description"};
  for (const auto& port : ports) {
    std::set<std::string> keys;
    for (const auto& [key, value] : port.items()) keys.insert(key);
    EXPECT_EQ(keys, fields) << port.dump();
  }
  EXPECT_EQ(ports[0]["device_kind"], "photo-research-meter");
  EXPECT_EQ(ports[0]["device_description"], "Photo Research meter");
  EXPECT_EQ(ports[0]["uri"], "usb:180b:0524:67012345");
  EXPECT_EQ(ports[0]["vendor_id"], "180b");
  EXPECT_EQ(ports[0]["product_id"], "0524");
  EXPECT_EQ(ports[0]["kind"], "usb");
  EXPECT_EQ(ports[1]["device_kind"], "rs232-adapter");
  EXPECT_EQ(ports[1]["device_description"], "FTDI FT232R RS-232 adapter");
  EXPECT_TRUE(ports[2]["device_kind"].is_null());
  EXPECT_EQ(ports[2]["uri"], "usb:2341:0043");
  EXPECT_TRUE(ports[3]["device_kind"].is_null());
  EXPECT_TRUE(ports[3]["vendor_id"].is_null());
  EXPECT_EQ(ports[3]["uri"], "serial:/dev/ttyS0");
}

TEST(PortsFormat, JsonIsOneLineEvenForBytesThatAreNotUtf8) {
  auto odd = usb_port("/dev/ttyACM0", 0x180b, 0x0524,
                      "67\xff"
                      "01");
  const auto line = cli::ports_json_line({odd});
  EXPECT_EQ(line.find('\n'), line.size() - 1);
  const auto ports = nlohmann::json::parse(line);
  EXPECT_EQ(ports[0]["serial_number"],
            "67\xef\xbf\xbd"
            "01");
  EXPECT_EQ(nlohmann::json::parse(cli::ports_json_line({})), nlohmann::json::array());
}

std::string line_of(const std::string& table, const std::string& path) {
  std::istringstream lines(table);
  for (std::string line; std::getline(lines, line);)
    if (line.starts_with(path + " ")) return line;
  return {};
}

TEST(PortsFormat, TheTableNamesTheDeviceOnItsPortsLine) {
  const auto table = cli::ports_table(a_bench());
  EXPECT_THAT(table.substr(0, table.find('\n')), HasSubstr("device"));
  EXPECT_THAT(line_of(table, "/dev/ttyACM0"), HasSubstr("Photo Research meter"));
  EXPECT_THAT(line_of(table, "/dev/ttyACM0"), HasSubstr("usb:180b:0524:67012345"));
  EXPECT_THAT(line_of(table, "/dev/ttyUSB0"), HasSubstr("FTDI FT232R RS-232 adapter"));
  EXPECT_THAT(line_of(table, "/dev/ttyUSB1"), Not(HasSubstr("Photo Research")));
  EXPECT_THAT(line_of(table, "/dev/ttyUSB1"), Not(HasSubstr("adapter")));
  EXPECT_THAT(line_of(table, "/dev/ttyS0"), HasSubstr("serial:/dev/ttyS0"));
  EXPECT_EQ(cli::ports_table({}), "no serial ports found\n");
}

// ---- The udev rule ----------------------------------------------------------------------------

std::string read_text(const char* path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

std::vector<testing::UdevRule> project_rules() {
  auto rules = testing::parse_udev_rules(read_text(UDEV_RULES_FILE));
  EXPECT_TRUE(rules) << UDEV_RULES_FILE << ": " << rules.error();
  return rules ? *rules : std::vector<testing::UdevRule>{};
}

UdevDevice usb_device_node(unsigned short vid, unsigned short pid) {
  return {"1-2",
          "usb",
          "usb",
          {{"DEVTYPE", "usb_device"}},
          {{"idVendor", fmt::format("{:04x}", vid)}, {"idProduct", fmt::format("{:04x}", pid)}}};
}

// The tty of a USB serial device, with the parents the kernel gives it: the interface, then the
// device that holds the ids. A CDC-ACM meter is ttyACM under cdc_acm; an adapter ttyUSB under
// its own driver and a usb-serial port.
UdevEvent tty_event(unsigned short vid, unsigned short pid, UsbDeviceKind kind) {
  UdevEvent event;
  const bool acm = kind == UsbDeviceKind::photo_research_meter;
  event.device = {acm ? "ttyACM0" : "ttyUSB0", "tty", "", {}, {}};
  if (!acm) event.parents.push_back({"ttyUSB0", "usb-serial", "ftdi_sio", {}, {}});
  event.parents.push_back({"1-2:1.0", "usb", acm ? "cdc_acm" : "ftdi_sio", {{"DEVTYPE", "usb_interface"}}, {}});
  event.parents.push_back(usb_device_node(vid, pid));
  return event;
}

UdevEvent usb_device_event(unsigned short vid, unsigned short pid) {
  UdevEvent event;
  event.device = usb_device_node(vid, pid);
  return event;
}

UdevOutcome run_rules(const std::vector<testing::UdevRule>& rules, const UdevEvent& event) {
  auto outcome = testing::apply_udev_rules(rules, event);
  EXPECT_TRUE(outcome) << outcome.error();
  return outcome ? *outcome : UdevOutcome{};
}

// Each row with a product id, and for a row of a whole vendor two products no row names.
std::vector<std::pair<KnownUsbDevice, unsigned short>> rows_with_products() {
  std::vector<std::pair<KnownUsbDevice, unsigned short>> rows;
  for (const auto& row : known_usb_devices()) {
    if (row.product_id) rows.emplace_back(row, *row.product_id);
    else
      for (const unsigned short pid : {0x0001, 0xfffe}) rows.emplace_back(row, pid);
  }
  return rows;
}

TEST(UdevRule, ReadsAsUdevSyntax) {
  const auto rules = project_rules();
  EXPECT_GE(rules.size(), 6u);
}

TEST(UdevRule, GivesTheGroupEveryKnownDevicesTtyAndUsbNode) {
  const auto rules = project_rules();
  for (const auto& [row, pid] : rows_with_products()) {
    SCOPED_TRACE(fmt::format("{:04x}:{:04x} {}", row.vendor_id, pid, row.description));
    const auto tty = run_rules(rules, tty_event(row.vendor_id, pid, row.kind));
    EXPECT_EQ(tty.group, "skinspec");
    EXPECT_EQ(tty.mode, "0660");
    const auto node = run_rules(rules, usb_device_event(row.vendor_id, pid));
    EXPECT_EQ(node.group, "skinspec");
    EXPECT_EQ(node.mode, "0660");
  }
}

TEST(UdevRule, KeepsModemManagerAwayFromEveryPhotoResearchMeter) {
  const auto rules = project_rules();
  for (const auto& [row, pid] : rows_with_products()) {
    if (row.kind != UsbDeviceKind::photo_research_meter) continue;
    SCOPED_TRACE(fmt::format("{:04x}:{:04x}", row.vendor_id, pid));
    EXPECT_EQ(run_rules(rules, tty_event(row.vendor_id, pid, row.kind)).env["ID_MM_DEVICE_IGNORE"], "1");
    EXPECT_EQ(run_rules(rules, usb_device_event(row.vendor_id, pid)).env["ID_MM_DEVICE_IGNORE"], "1");
  }
}

TEST(UdevRule, LeavesOtherDevicesAlone) {
  const auto rules = project_rules();
  for (const auto& [vid, pid] :
       std::vector<std::pair<unsigned short, unsigned short>>{{0x2341, 0x0043}, {0x0403, 0x6010}, {0x0524, 0x180b}}) {
    SCOPED_TRACE(fmt::format("{:04x}:{:04x}", vid, pid));
    const auto tty = run_rules(rules, tty_event(vid, pid, UsbDeviceKind::photo_research_meter));
    EXPECT_FALSE(tty.group);
    EXPECT_FALSE(tty.mode);
    EXPECT_FALSE(tty.env.contains("ID_MM_DEVICE_IGNORE"));
  }
  UdevEvent serial_port;
  serial_port.device = {"ttyS0", "tty", "", {}, {}};
  EXPECT_FALSE(run_rules(rules, serial_port).group);
  // The interface between tty and device holds no ids: the rules for USB nodes skip it.
  UdevEvent interface;
  interface.device = {"1-2:1.0", "usb", "cdc_acm", {{"DEVTYPE", "usb_interface"}}, {}};
  interface.parents.push_back(usb_device_node(0x180b, 0x0524));
  EXPECT_FALSE(run_rules(rules, interface).group);
}

// The converse of the table's rows reaching the rule: every product the rule lets in is a row,
// so that the rule grants nothing skinspec does not know.
TEST(UdevRule, LetsInOnlyDevicesOfTheTable) {
  for (const auto& rule : project_rules()) {
    std::vector<std::string> vendors, products;
    bool tty = false;
    for (const auto& key : rule.keys) {
      if (key.key == "SUBSYSTEM" && key.value == "tty") tty = true;
      if (key.key == "ATTRS" && key.attribute == "idVendor") vendors.push_back(key.value);
      if (key.key == "ATTRS" && key.attribute == "idProduct") products.push_back(key.value);
    }
    if (!tty) continue;
    ASSERT_EQ(vendors.size(), 1u) << "line " << rule.line;
    for (const auto& vendor : std::views::split(vendors.front(), '|')) {
      const auto vid = static_cast<unsigned short>(std::stoul(std::string(vendor.begin(), vendor.end()), nullptr, 16));
      if (products.empty()) {
        const auto row = std::ranges::find_if(known_usb_devices(),
                                              [&](const auto& r) { return r.vendor_id == vid && !r.product_id; });
        EXPECT_NE(row, known_usb_devices().end()) << fmt::format("line {}: vendor {:04x}", rule.line, vid);
        continue;
      }
      for (const auto& product : std::views::split(products.front(), '|')) {
        const auto pid =
            static_cast<unsigned short>(std::stoul(std::string(product.begin(), product.end()), nullptr, 16));
        const auto known = classify_usb_device(vid, pid);
        EXPECT_TRUE(known && known->product_id == pid) << fmt::format("line {}: {:04x}:{:04x}", rule.line, vid, pid);
      }
    }
  }
}

// ---- The reader itself: it must refuse what udev refuses, or the checks above prove little --------

TEST(UdevRuleReader, RefusesWhatUdevWouldNot) {
  for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
           {"SUBSYTEM==\"tty\", GROUP=\"x\"", "line 1: unknown key SUBSYTEM"},
           {"# comment\n\nSUBSYSTEM=\"tty\"", "line 3: SUBSYSTEM does not take ="},
           {"GROUP==\"x\"", "GROUP does not take =="},
           {"ATTRS==\"x\"", "ATTRS needs {name}"},
           {"GROUP{x}=\"y\"", "GROUP takes no {x}"},
           {"SUBSYSTEM==tty", "not quoted"},
           {"SUBSYSTEM==\"tty", "unterminated value"},
           {"SUBSYSTEM==\"tty\" GROUP=\"x\"", "expected ','"},
           {"SUBSYSTEM==\"tty\",", "a ',' ends the line"},
           {"SUBSYSTEM~\"tty\"", "expected an operator"}}) {
    const auto rules = testing::parse_udev_rules(text);
    ASSERT_FALSE(rules) << text;
    EXPECT_THAT(rules.error(), HasSubstr(expected)) << text;
  }
}

TEST(UdevRuleReader, MatchesLikeUdev) {
  const auto rules = testing::parse_udev_rules(
      "SUBSYSTEM==\"tty\", ATTRS{idVendor}==\"12ab|34cd\", ATTRS{idProduct}!=\"00*\", GROUP=\"one\"\n"
      "ENV{SEEN}!=\"\", MODE:=\"0600\"\n"
      "SUBSYSTEM==\"tty\", ENV{SEEN}=\"yes\", MODE=\"0666\"\n"
      "ENV{SEEN}==\"yes\", MODE=\"0644\", SYMLINK+=\"meter\"\n");
  ASSERT_TRUE(rules) << rules.error();
  UdevEvent event;
  event.device = {"ttyACM0", "tty", "", {}, {}};
  event.parents.push_back({"1-2", "usb", "usb", {}, {{"idVendor", "34cd"}, {"idProduct", "0100"}}});
  auto outcome = testing::apply_udev_rules(*rules, event);
  ASSERT_TRUE(outcome) << outcome.error();
  EXPECT_EQ(outcome->group, "one");
  EXPECT_EQ(outcome->mode, "0644");  // the := came before SEEN was set, so it did not apply
  EXPECT_EQ(outcome->symlinks, std::vector<std::string>{"meter"});

  event.parents.front().attributes["idProduct"] = "0042";
  EXPECT_FALSE(testing::apply_udev_rules(*rules, event)->group);

  // The ids must be found on one and the same parent.
  event.parents = {{"1-2:1.0", "usb", "", {}, {{"idVendor", "12ab"}}}, {"1-2", "usb", "", {}, {{"idProduct", "0100"}}}};
  EXPECT_FALSE(testing::apply_udev_rules(*rules, event)->group);
}

TEST(UdevRuleReader, SaysWhatItCannotEvaluate) {
  const auto rules = testing::parse_udev_rules("SUBSYSTEM==\"tty\", GOTO=\"end\"\nLABEL=\"end\"\n");
  ASSERT_TRUE(rules) << rules.error();
  UdevEvent event;
  event.device = {"ttyS0", "tty", "", {}, {}};
  const auto outcome = testing::apply_udev_rules(*rules, event);
  ASSERT_FALSE(outcome);
  EXPECT_THAT(outcome.error(), HasSubstr("GOTO"));
}

}  // namespace
}  // namespace skinspec::drivers
