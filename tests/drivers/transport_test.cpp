// Transports and discovery: URI parsing, the in-process pair, TCP on loopback against a
// server run by the test, what can be checked of serial ports without hardware, and that
// discovery neither crashes nor hangs on a machine without USB.
//
// Deadlines are checked only for ending the wait: a 100 ms timeout must return within
// seconds, never within some tight bound, so a loaded machine cannot fail these tests.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <functional>
#include <future>
#include <nlohmann/json.hpp>
#include <thread>

#include "skinspec/drivers/discovery.hpp"
#include "skinspec/drivers/memory_transport.hpp"
#include "skinspec/drivers/open_instrument.hpp"
#include "skinspec/drivers/transport.hpp"
#include "skinspec/testkit/process.hpp"

namespace skinspec::drivers {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using Kind = TransportError::Kind;

// Long enough that only a broken wait could reach it.
constexpr auto kGenerous = 10s;

ConnectionUri parse(std::string_view text) {
  auto uri = parse_connection_uri(text);
  EXPECT_TRUE(uri.has_value()) << text << ": " << (uri ? "" : uri.error());
  return uri.value_or(ConnectionUri{});
}

// Reads until `count` bytes have come or the read fails.
std::string read_exactly(Transport& transport, std::size_t count, Deadline deadline = deadline_in(kGenerous)) {
  std::string received;
  char buffer[64];
  while (received.size() < count) {
    auto n = transport.read(buffer, std::min(sizeof buffer, count - received.size()), deadline);
    if (!n) break;
    received.append(buffer, *n);
  }
  return received;
}

// How long a call took, to check that a wait ended at all.
template <typename Call>
Clock::duration time_of(Call&& call) {
  const auto start = Clock::now();
  call();
  return Clock::now() - start;
}

// ---- URIs ---------------------------------------------------------------------------------

TEST(ConnectionUri, SerialDefaultsToThePR650LineSettings) {
  const auto uri = parse("serial:/dev/ttyUSB0");
  EXPECT_EQ(uri.scheme, ConnectionUri::Scheme::serial);
  EXPECT_EQ(uri.path, "/dev/ttyUSB0");
  EXPECT_EQ(uri.baud, 9600u);
  EXPECT_EQ(uri.flow, ConnectionUri::Flow::none);
  EXPECT_EQ(uri.terminator, std::nullopt) << "each family's own";
  EXPECT_EQ(uri.pacing_ms, std::nullopt) << "each model's own";
}

TEST(ConnectionUri, SerialOptions) {
  const auto uri = parse("serial:/dev/ttyS1?baud=19200&flow=rtscts&terminator=cr");
  EXPECT_EQ(uri.path, "/dev/ttyS1");
  EXPECT_EQ(uri.baud, 19200u);
  EXPECT_EQ(uri.flow, ConnectionUri::Flow::rtscts);
  EXPECT_EQ(uri.terminator, '\r');
  EXPECT_EQ(parse("serial:/dev/ttyS1?flow=xonxoff").flow, ConnectionUri::Flow::xonxoff);
  EXPECT_EQ(parse("serial:/dev/ttyS1?terminator=lf").terminator, '\n');
  EXPECT_EQ(parse("serial:/dev/ttyS1?pacing_ms=0").pacing_ms, 0);
  EXPECT_EQ(parse("usb:180b:0524?pacing_ms=75&terminator=LF").pacing_ms, 75);
  EXPECT_EQ(parse("usb:180b:0524?pacing_ms=1000").pacing_ms, 1000);
}

TEST(ConnectionUri, TcpHostsAndPorts) {
  const auto ipv4 = parse("tcp:192.168.1.20:4001");
  EXPECT_EQ(ipv4.scheme, ConnectionUri::Scheme::tcp);
  EXPECT_EQ(ipv4.host, "192.168.1.20");
  EXPECT_EQ(ipv4.port, 4001);
  EXPECT_EQ(parse("tcp:[::1]:4001").host, "::1");
  EXPECT_EQ(parse("tcp:[::1]:4001").port, 4001);
  EXPECT_EQ(parse("tcp:lab-server.local:65535?terminator=cr").host, "lab-server.local");
  EXPECT_EQ(parse("tcp:lab-server.local:65535?terminator=cr").terminator, '\r');
  EXPECT_EQ(parse("tcp:lab-server.local:4001?pacing_ms=50").pacing_ms, 50) << "a serial server relays bytes as written";
}

TEST(ConnectionUri, UsbIdsAreHex) {
  const auto uri = parse("usb:067b:2303");
  EXPECT_EQ(uri.scheme, ConnectionUri::Scheme::usb);
  EXPECT_EQ(uri.vendor_id, 0x067b);
  EXPECT_EQ(uri.product_id, 0x2303);
  EXPECT_TRUE(uri.usb_serial.empty());
  const auto with_serial = parse("usb:0403:6001:A12:B?baud=4800");
  EXPECT_EQ(with_serial.vendor_id, 0x0403);
  EXPECT_EQ(with_serial.usb_serial, "A12:B");
  EXPECT_EQ(with_serial.baud, 4800u);
  EXPECT_EQ(parse("usb:ABCD:1").vendor_id, 0xabcd);
}

TEST(ConnectionUri, PrintsBackWhatItParsed) {
  for (const char* text :
       {"serial:/dev/ttyUSB0", "serial:/dev/ttyS0?baud=19200&flow=xonxoff&terminator=cr", "tcp:127.0.0.1:4001",
        "tcp:[::1]:4001?terminator=cr", "usb:067b:2303", "usb:0403:6001:FT1234?flow=rtscts",
        "serial:/dev/x?terminator=lf", "tcp:127.0.0.1:4001?terminator=lf&pacing_ms=0", "usb:180b:0524?pacing_ms=50"})
    EXPECT_EQ(parse(text).to_string(), text);
  EXPECT_EQ(parse("usb:67B:2303").to_string(), "usb:067b:2303");
  EXPECT_EQ(parse("serial:/dev/x?baud=9600&flow=none").to_string(), "serial:/dev/x");
  EXPECT_EQ(parse("serial:/dev/x?pacing_ms=20&terminator=cr").to_string(), "serial:/dev/x?terminator=cr&pacing_ms=20");
}

TEST(ConnectionUri, AnUnsetTerminatorIsEachFamilysOwnAndASetOneIsEveryones) {
  const auto defaults = instrument_options_for(parse("serial:/dev/ttyUSB0"));
  EXPECT_EQ(defaults.pr650.style.terminator, '\n');
  EXPECT_EQ(defaults.remote.style.terminator, '\r');
  EXPECT_EQ(defaults.remote.pacing, std::nullopt);
  for (const auto& [text, terminator] :
       {std::pair{"serial:/dev/x?terminator=lf", '\n'}, std::pair{"tcp:127.0.0.1:4001?terminator=cr", '\r'}}) {
    const auto options = instrument_options_for(parse(text));
    EXPECT_EQ(options.pr650.style.terminator, terminator) << text;
    EXPECT_EQ(options.remote.style.terminator, terminator) << text;
  }
  EXPECT_EQ(instrument_options_for(parse("usb:180b:0524?pacing_ms=0")).remote.pacing, 0ms);
  EXPECT_EQ(instrument_options_for(parse("usb:180b:0524?pacing_ms=80")).remote.pacing, 80ms);
  EXPECT_EQ(instrument_options_for(parse("serial:/dev/x?baud=19200")).remote.timing.line_bytes_per_second, 1920);
  EXPECT_EQ(instrument_options_for(parse("tcp:127.0.0.1:4001")).remote.timing.line_bytes_per_second, 960);
}

struct BadUri {
  const char* text;
  const char* names;  // what the message must mention
};

class BadConnectionUri : public ::testing::TestWithParam<BadUri> {};

TEST_P(BadConnectionUri, IsRefusedNamingTheBadPart) {
  const auto uri = parse_connection_uri(GetParam().text);
  ASSERT_FALSE(uri.has_value()) << GetParam().text;
  EXPECT_THAT(uri.error(), HasSubstr(GetParam().names));
  EXPECT_THAT(uri.error(), HasSubstr("bad connection URI"));
}

INSTANTIATE_TEST_SUITE_P(
    EveryKind, BadConnectionUri,
    ::testing::Values(BadUri{"", "empty"}, BadUri{"/dev/ttyUSB0", "no scheme"}, BadUri{"com:3", "unknown scheme 'com'"},
                      BadUri{"serial:", "no device path"}, BadUri{"serial:/dev/tty USB0", "spaces"},
                      BadUri{"tcp:localhost", "no port"}, BadUri{"tcp::4001", "no host"},
                      BadUri{"tcp:host:0", "port '0'"}, BadUri{"tcp:host:70000", "port '70000'"},
                      BadUri{"tcp:host:40x1", "port '40x1'"}, BadUri{"tcp:host:", "port ''"},
                      BadUri{"tcp:::1:4001", "brackets"}, BadUri{"tcp:[::1:4001", "closing ']'"},
                      BadUri{"tcp:[::1]", "':PORT'"}, BadUri{"tcp:[]:4001", "empty host"},
                      BadUri{"usb:067b", "usb:VID:PID"}, BadUri{"usb:067g:2303", "vendor id '067g'"},
                      BadUri{"usb:067b:23030", "product id '23030'"}, BadUri{"usb::2303", "vendor id ''"},
                      BadUri{"usb:067b:2303:", "empty serial"},
                      BadUri{"serial:/dev/x?parity=even", "unknown option 'parity'"},
                      BadUri{"tcp:host:1?baud=9600", "unknown option 'baud'"},
                      BadUri{"serial:/dev/x?baud=9600&baud=4800", "'baud' is given twice"},
                      BadUri{"serial:/dev/x?baud", "'baud' has no '=value'"},
                      BadUri{"serial:/dev/x?baud=", "empty value"}, BadUri{"serial:/dev/x?baud=fast", "baud 'fast'"},
                      BadUri{"serial:/dev/x?baud=0", "baud '0'"}, BadUri{"serial:/dev/x?flow=dtrdsr", "flow 'dtrdsr'"},
                      BadUri{"serial:/dev/x?terminator=crlf", "terminator 'crlf'"},
                      BadUri{"serial:/dev/x?pacing_ms=-1", "pacing_ms '-1'"},
                      BadUri{"tcp:host:1?pacing_ms=1001", "pacing_ms '1001' is not a whole number from 0 to 1000"},
                      BadUri{"serial:/dev/x?pacing_ms=50ms", "pacing_ms '50ms'"},
                      BadUri{"serial:/dev/x?baud=9600&", "stray"}, BadUri{"serial:/dev/x?", "stray"}));

TEST(TransportErrorKind, HasNames) {
  EXPECT_EQ(to_string(Kind::timeout), "timeout");
  EXPECT_EQ(to_string(Kind::interrupted), "interrupted");
  EXPECT_EQ(to_string(Kind::closed), "closed");
  EXPECT_EQ(to_string(Kind::io), "io");
  EXPECT_EQ(to_string(Kind::not_found), "not_found");
}

// ---- The memory pair ------------------------------------------------------------------------

TEST(MemoryPair, CarriesBytesBothWays) {
  auto [a, b] = make_memory_pair("sim");
  EXPECT_TRUE(a->is_open());
  EXPECT_EQ(a->describe(), "sim:a");
  EXPECT_EQ(b->describe(), "sim:b");
  ASSERT_TRUE(a->write("b3\n", deadline_in(1s)));
  EXPECT_EQ(read_exactly(*b, 3), "b3\n");
  ASSERT_TRUE(b->write("000\r\n", deadline_in(1s)));
  EXPECT_EQ(read_exactly(*a, 5), "000\r\n");
}

TEST(MemoryPair, ReadsNoMoreThanTheBufferHolds) {
  auto [a, b] = make_memory_pair();
  ASSERT_TRUE(a->write("abcdef", deadline_in(1s)));
  char buffer[4];
  auto n = b->read(buffer, sizeof buffer, deadline_in(1s));
  ASSERT_TRUE(n);
  EXPECT_EQ(std::string(buffer, *n), "abcd");
  EXPECT_EQ(read_exactly(*b, 2), "ef");
}

TEST(MemoryPair, FlushDiscardsWhatWasNotRead) {
  auto [a, b] = make_memory_pair();
  ASSERT_TRUE(a->write("stale", deadline_in(1s)));
  ASSERT_TRUE(b->flush_input());
  ASSERT_TRUE(a->write("new", deadline_in(1s)));
  EXPECT_EQ(read_exactly(*b, 3), "new");
}

TEST(MemoryPair, ReadEndsAtTheDeadline) {
  auto [a, b] = make_memory_pair();
  char buffer[8];
  std::expected<std::size_t, TransportError> result;
  EXPECT_LT(time_of([&] { result = b->read(buffer, sizeof buffer, deadline_in(100ms)); }), kGenerous);
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, Kind::timeout);
}

TEST(MemoryPair, InterruptFromAnotherThreadEndsABlockedRead) {
  auto [a, b] = make_memory_pair();
  auto interrupter = std::async(std::launch::async, [&reader = *b] {
    std::this_thread::sleep_for(50ms);
    reader.interrupt();
  });
  char buffer[8];
  std::expected<std::size_t, TransportError> result;
  EXPECT_LT(time_of([&] { result = b->read(buffer, sizeof buffer, deadline_in(60s)); }), kGenerous);
  interrupter.get();
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, Kind::interrupted);

  // It stays interrupted until cleared, then works again.
  EXPECT_EQ(b->read(buffer, sizeof buffer, deadline_in(1s)).error().kind, Kind::interrupted);
  b->clear_interrupt();
  ASSERT_TRUE(a->write("x", deadline_in(1s)));
  EXPECT_EQ(read_exactly(*b, 1), "x");
}

TEST(MemoryPair, CloseLetsThePeerDrainThenReportsClosed) {
  auto [a, b] = make_memory_pair();
  ASSERT_TRUE(a->write("last words", deadline_in(1s)));
  a->close();
  EXPECT_FALSE(a->is_open());
  EXPECT_EQ(read_exactly(*b, 10), "last words");
  char buffer[8];
  EXPECT_EQ(b->read(buffer, sizeof buffer, deadline_in(5s)).error().kind, Kind::closed);
  EXPECT_EQ(b->write("anyone?", deadline_in(1s)).error().kind, Kind::closed);
  EXPECT_EQ(a->read(buffer, sizeof buffer, deadline_in(1s)).error().kind, Kind::closed);

  ASSERT_TRUE(a->open());
  ASSERT_TRUE(b->write("again", deadline_in(1s)));
  EXPECT_EQ(read_exactly(*a, 5), "again");
}

TEST(MemoryPair, DestroyingAnEndClosesIt) {
  auto [a, b] = make_memory_pair();
  a.reset();
  char buffer[8];
  EXPECT_EQ(b->read(buffer, sizeof buffer, deadline_in(5s)).error().kind, Kind::closed);
}

TEST(MemoryPair, RecordsModemLines) {
  auto [a, b] = make_memory_pair();
  auto& host = dynamic_cast<MemoryTransport&>(*a);
  auto& instrument = dynamic_cast<MemoryTransport&>(*b);
  ASSERT_TRUE(a->set_modem_lines(false, false));
  ASSERT_TRUE(a->set_modem_lines(true, true));
  const std::vector<ModemLines> toggled{{false, false}, {true, true}};
  EXPECT_EQ(host.modem_line_changes(), toggled);
  EXPECT_EQ(instrument.peer_modem_line_changes(), toggled);
  EXPECT_TRUE(instrument.modem_line_changes().empty());
}

// ---- TCP on loopback ------------------------------------------------------------------------

namespace asio = boost::asio;
using asio::ip::tcp;

// A server on 127.0.0.1 that accepts one connection and runs `script` on it in its own thread.
class ScriptedServer {
 public:
  explicit ScriptedServer(std::function<void(tcp::socket&)> script)
      : acceptor_(io_, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0)) {
    thread_ = std::thread([this, script = std::move(script)] {
      tcp::socket socket(io_);
      boost::system::error_code error;
      acceptor_.accept(socket, error);
      accepted_ = true;
      if (!error && !abandoned_) script(socket);
    });
  }
  // A test that never connected leaves the thread in accept(): connect once to free it.
  ~ScriptedServer() {
    if (!accepted_) {
      abandoned_ = true;
      tcp::socket poke(io_);
      boost::system::error_code ignored;
      poke.connect(acceptor_.local_endpoint(), ignored);
    }
    thread_.join();
  }
  std::string uri() const { return "tcp:127.0.0.1:" + std::to_string(acceptor_.local_endpoint().port()); }

 private:
  asio::io_context io_;
  tcp::acceptor acceptor_;
  std::atomic<bool> accepted_{false}, abandoned_{false};
  std::thread thread_;
};

// Sends back what it receives until the client hangs up.
void echo(tcp::socket& socket) {
  char buffer[256];
  boost::system::error_code error;
  for (;;) {
    const std::size_t n = socket.read_some(asio::buffer(buffer), error);
    if (error) return;
    asio::write(socket, asio::buffer(buffer, n), error);
    if (error) return;
  }
}

// Says nothing and waits for the client to hang up.
void silent(tcp::socket& socket) {
  char buffer[256];
  boost::system::error_code error;
  while (!error) socket.read_some(asio::buffer(buffer), error);
}

std::unique_ptr<Transport> tcp_transport(const ScriptedServer& server) {
  auto transport = make_transport(parse(server.uri()));
  EXPECT_TRUE(transport.has_value());
  return std::move(transport).value();
}

TEST(TcpTransport, WritesAndReadsThroughTheConnection) {
  ScriptedServer server(echo);
  auto transport = tcp_transport(server);
  EXPECT_FALSE(transport->is_open());
  ASSERT_TRUE(transport->open());
  EXPECT_TRUE(transport->is_open());
  EXPECT_EQ(transport->describe(), server.uri());
  ASSERT_TRUE(transport->set_modem_lines(true, true));  // accepted and ignored
  ASSERT_TRUE(transport->write("d5\n", deadline_in(kGenerous)));
  EXPECT_EQ(read_exactly(*transport, 3), "d5\n");
}

TEST(TcpTransport, ReadEndsAtTheDeadline) {
  ScriptedServer server(silent);
  auto transport = tcp_transport(server);
  ASSERT_TRUE(transport->open());
  char buffer[8];
  std::expected<std::size_t, TransportError> result;
  EXPECT_LT(time_of([&] { result = transport->read(buffer, sizeof buffer, deadline_in(100ms)); }), kGenerous);
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, Kind::timeout);
}

TEST(TcpTransport, PeerCloseIsClosed) {
  ScriptedServer server([](tcp::socket& socket) { asio::write(socket, asio::buffer("bye", 3)); });
  auto transport = tcp_transport(server);
  ASSERT_TRUE(transport->open());
  EXPECT_EQ(read_exactly(*transport, 3), "bye");
  char buffer[8];
  auto result = transport->read(buffer, sizeof buffer, deadline_in(kGenerous));
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, Kind::closed);
}

TEST(TcpTransport, ConnectingToAClosedPortFails) {
  std::string uri;
  {
    asio::io_context io;
    tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
    uri = "tcp:127.0.0.1:" + std::to_string(acceptor.local_endpoint().port());
  }
  auto transport = make_transport(parse(uri));
  ASSERT_TRUE(transport);
  auto opened = (*transport)->open();
  ASSERT_FALSE(opened);
  EXPECT_NE(opened.error().kind, Kind::timeout);
  EXPECT_THAT(opened.error().message, HasSubstr(uri));
  EXPECT_FALSE((*transport)->is_open());
}

TEST(TcpTransport, InterruptFromAnotherThreadEndsABlockedRead) {
  ScriptedServer server(echo);
  auto transport = tcp_transport(server);
  ASSERT_TRUE(transport->open());
  auto interrupter = std::async(std::launch::async, [&transport] {
    std::this_thread::sleep_for(50ms);
    transport->interrupt();
  });
  char buffer[8];
  std::expected<std::size_t, TransportError> result;
  EXPECT_LT(time_of([&] { result = transport->read(buffer, sizeof buffer, deadline_in(60s)); }), kGenerous);
  interrupter.get();
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error().kind, Kind::interrupted);

  // A cleared interrupt leaves nothing behind to cancel the next exchange.
  transport->clear_interrupt();
  ASSERT_TRUE(transport->write("ok", deadline_in(kGenerous)));
  EXPECT_EQ(read_exactly(*transport, 2), "ok");
}

TEST(TcpTransport, InterruptBeforeACallEndsIt) {
  ScriptedServer server(echo);
  auto transport = tcp_transport(server);
  ASSERT_TRUE(transport->open());
  transport->interrupt();
  EXPECT_EQ(transport->write("x", deadline_in(kGenerous)).error().kind, Kind::interrupted);
  char buffer[8];
  EXPECT_EQ(transport->read(buffer, sizeof buffer, deadline_in(kGenerous)).error().kind, Kind::interrupted);
}

TEST(TcpTransport, FlushDiscardsWhatArrived) {
  ScriptedServer server([](tcp::socket& socket) {
    asio::write(socket, asio::buffer("stale", 5));
    echo(socket);
  });
  auto transport = tcp_transport(server);
  ASSERT_TRUE(transport->open());
  EXPECT_EQ(read_exactly(*transport, 1), "s");
  std::this_thread::sleep_for(100ms);  // lets the rest of the (single, tiny) segment settle
  ASSERT_TRUE(transport->flush_input());
  ASSERT_TRUE(transport->write("new", deadline_in(kGenerous)));
  EXPECT_EQ(read_exactly(*transport, 3), "new");
}

TEST(TcpTransport, NotOpenIsClosed) {
  ScriptedServer server(silent);
  auto transport = tcp_transport(server);
  char buffer[8];
  EXPECT_EQ(transport->read(buffer, sizeof buffer, deadline_in(1s)).error().kind, Kind::closed);
  EXPECT_EQ(transport->write("x", deadline_in(1s)).error().kind, Kind::closed);
}

// ---- Serial -----------------------------------------------------------------------------------

TEST(SerialTransport, MissingDeviceIsNotFound) {
  auto transport = make_transport(parse("serial:/dev/skinspec-no-such-port"));
  ASSERT_TRUE(transport);
  EXPECT_FALSE((*transport)->is_open());
  EXPECT_EQ((*transport)->describe(), "serial:/dev/skinspec-no-such-port");
  auto opened = (*transport)->open();
  ASSERT_FALSE(opened);
  EXPECT_EQ(opened.error().kind, Kind::not_found);
  EXPECT_THAT(opened.error().message, HasSubstr("/dev/skinspec-no-such-port"));
  char buffer[8];
  EXPECT_EQ((*transport)->read(buffer, sizeof buffer, deadline_in(1s)).error().kind, Kind::closed);
}

// ---- Discovery --------------------------------------------------------------------------------

TEST(Discovery, ListsPortsWithoutFailing) {
  for (const auto& port : list_ports()) {
    EXPECT_FALSE(port.path.empty());
    EXPECT_THAT((std::vector<std::string>{"usb", "native", "bluetooth", "unknown"}), ::testing::Contains(port.kind));
  }
}

TEST(Discovery, AnAbsentAdapterIsNamed) {
  const auto found = find_usb_port(0xfffe, 0xfffd, "NOPE42");
  ASSERT_FALSE(found);
  EXPECT_THAT(found.error(), HasSubstr("fffe:fffd"));
  EXPECT_THAT(found.error(), HasSubstr("NOPE42"));

  const auto transport = make_transport(parse("usb:fffe:fffd"));
  ASSERT_FALSE(transport);
  EXPECT_THAT(transport.error(), HasSubstr("fffe:fffd"));
}

TEST(Discovery, HotplugMonitorStartsAndStopsPromptly) {
  std::atomic<int> events{0};
  const auto elapsed = time_of([&] {
    auto monitor = HotplugMonitor::start([&](const UsbDeviceEvent&) { ++events; }, 20ms);
    ASSERT_NE(monitor, nullptr);
    std::this_thread::sleep_for(100ms);
    monitor->stop();
    monitor->stop();  // idempotent
  });
  EXPECT_LT(elapsed, kGenerous);
}

TEST(Discovery, HotplugMonitorStopsWhenDestroyed) {
  const auto elapsed = time_of([] { auto monitor = HotplugMonitor::start([](const UsbDeviceEvent&) {}, 20ms); });
  EXPECT_LT(elapsed, kGenerous);
}

// ---- skinspec ports ----------------------------------------------------------------------------

TEST(PortsCommand, PrintsAJsonArrayEvenWhenEmpty) {
  const auto result = skinspec::testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", {"ports", "--json"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  const auto ports = nlohmann::json::parse(result.out);
  ASSERT_TRUE(ports.is_array()) << result.out;
  for (const auto& port : ports) {
    EXPECT_TRUE(port.contains("path")) << port.dump();
    EXPECT_TRUE(port.contains("uri")) << port.dump();
  }
}

TEST(PortsCommand, PrintsATableForPeople) {
  const auto result = skinspec::testing::run_process(SKINSPEC_TEST_BIN_DIR "/skinspec", {"ports"});
  ASSERT_EQ(result.exit_status, 0) << result.describe();
  EXPECT_FALSE(result.out.empty());
}

}  // namespace
}  // namespace skinspec::drivers
