// The tool's device links (tools/cli/device_link.hpp, glove_link.hpp) on loopback sockets, where
// every platform has them: natively, under Wine for Windows and under qemu-user for ARM64. A thread
// here is the device: it sends a glove's frames over TCP, drops the connection and takes the next one
// with a Hello that goes on counting, or sends them as UDP datagrams leaving some out; the link must
// pass on exactly the frames sent, count the rest as lost and reconnect. Serial ports are not here:
// Wine cannot emulate one, and a pty stands for one in tests/python/test_device_link.py (Linux).
#include <doctest/doctest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/write.hpp>

#include "cli/byte_link.hpp"
#include "cli/glove_link.hpp"

#ifdef _WIN32
#  include <windows.h>
#else
#  include <fcntl.h>
#  include <sys/stat.h>
#  include <unistd.h>
#endif

namespace {

using namespace glovepose;
using boost::asio::ip::tcp;
using boost::asio::ip::udp;
using Bytes = std::vector<std::uint8_t>;

constexpr std::uint64_t kCycleUs = 16667;

// A device's frames: a Hello (sequence `first`), then `count` Cells frames of one value each, the
// value being the frame's sequence number.
struct Device {
  std::uint32_t serial = 77;
  std::uint32_t next = 0;  // the next sequence number

  Bytes hello(std::uint64_t time_us) {
    device::FrameWriter w(next++);
    const auto f = w.hello(time_us, serial, 0, 1, "glauser2019");
    return Bytes(f.begin(), f.end());
  }
  Bytes reading() {
    device::FrameWriter w(next);
    const float value = static_cast<float>(next);
    const auto f = w.values(device::FrameKind::Cells, 1000000 + kCycleUs * next, &value, 1);
    ++next;
    return Bytes(f.begin(), f.end());
  }
};

// Polls `link` until `enough` readings came or 20 s passed; returns the readings' sequence numbers.
std::vector<std::uint32_t> read_until(cli::GloveLink& link, std::size_t enough) {
  std::vector<std::uint32_t> got;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (got.size() < enough && std::chrono::steady_clock::now() < give_up)
    link.poll(std::chrono::milliseconds(50), [&](const device::Frame& f, double, double) {
      if (f.header.kind != device::FrameKind::Cells) return;
      float value = 0;
      REQUIRE(device::read_values(f, &value, 1) == Status::Ok);
      CHECK(value == static_cast<float>(f.header.sequence));
      got.push_back(f.header.sequence);
    });
  return got;
}

cli::LinkTiming quick() {
  cli::LinkTiming t;
  t.first = std::chrono::milliseconds(10);
  t.longest = std::chrono::milliseconds(100);
  t.silence = std::chrono::milliseconds(500);
  return t;
}

// A TCP device's listening end on a free loopback port; address() is what a link opens.
struct LoopbackListener {
  boost::asio::io_context io;
  tcp::acceptor acceptor{io, tcp::endpoint(boost::asio::ip::make_address("127.0.0.1"), 0)};
  std::string address() const { return "tcp:127.0.0.1:" + std::to_string(acceptor.local_endpoint().port()); }
};

// A pipe the test writes to and a ByteSource opens by its path: a FIFO on POSIX, a named pipe on
// Windows (both a pipe to the reader, as stdin is when a program feeds the tool).
class WrittenPipe {
 public:
  WrittenPipe() {
#ifdef _WIN32
    path_ = "\\\\.\\pipe\\glovepose-test-" + std::to_string(::GetCurrentProcessId());
    handle_ = ::CreateNamedPipeA(path_.c_str(), PIPE_ACCESS_OUTBOUND, PIPE_TYPE_BYTE | PIPE_WAIT, 1, 4096, 4096, 0, nullptr);
    REQUIRE(handle_ != INVALID_HANDLE_VALUE);
#else
    path_ = "glovepose-test-fifo-" + std::to_string(::getpid());
    (void)::unlink(path_.c_str());
    REQUIRE(::mkfifo(path_.c_str(), 0600) == 0);
    fd_ = ::open(path_.c_str(), O_RDWR);  // a writer from the start: the reader's open returns at once
    REQUIRE(fd_ >= 0);
#endif
  }
  WrittenPipe(const WrittenPipe&) = delete;
  WrittenPipe& operator=(const WrittenPipe&) = delete;
  ~WrittenPipe() {
    close();
#ifndef _WIN32
    (void)::unlink(path_.c_str());
#endif
  }
  const std::string& path() const { return path_; }
  // After the reader opened the path.
  void write(const std::string& bytes) {
#ifdef _WIN32
    (void)::ConnectNamedPipe(handle_, nullptr);  // the reader is connected already (ERROR_PIPE_CONNECTED)
    DWORD written = 0;
    REQUIRE(::WriteFile(handle_, bytes.data(), static_cast<DWORD>(bytes.size()), &written, nullptr));
    REQUIRE(written == bytes.size());
#else
    REQUIRE(::write(fd_, bytes.data(), bytes.size()) == static_cast<ssize_t>(bytes.size()));
#endif
  }
  void close() {
#ifdef _WIN32
    if (handle_ != INVALID_HANDLE_VALUE) (void)::CloseHandle(handle_);
    handle_ = INVALID_HANDLE_VALUE;
#else
    if (fd_ >= 0) (void)::close(fd_);
    fd_ = -1;
#endif
  }

 private:
  std::string path_;
#ifdef _WIN32
  HANDLE handle_ = INVALID_HANDLE_VALUE;
#else
  int fd_ = -1;
#endif
};

}  // namespace

TEST_CASE("link: names of links are parsed, wrong ones refused with what was expected") {
  using Kind = cli::LinkAddress::Kind;
  CHECK(cli::LinkAddress::parse("-").kind == Kind::Stdin);
  const cli::LinkAddress serial = cli::LinkAddress::parse("serial:COM3@921600");
  CHECK((serial.kind == Kind::Serial && serial.where == "COM3" && serial.baud == 921600));
  CHECK(cli::LinkAddress::parse("serial:/dev/ttyACM0").baud == 115200);
  const cli::LinkAddress t = cli::LinkAddress::parse("tcp:glove.local:5000");
  CHECK((t.kind == Kind::Tcp && t.where == "glove.local" && t.port == 5000));
  const cli::LinkAddress u = cli::LinkAddress::parse("udp:9000");
  CHECK((u.kind == Kind::Udp && u.where == "0.0.0.0" && u.port == 9000 && u.reconnects()));
  CHECK(cli::LinkAddress::parse("take.gpw").kind == Kind::File);
  CHECK_THROWS_WITH_AS(cli::LinkAddress::parse("udp:70000"), doctest::Contains("expected a whole number from 1 to 65535"), Error);
  CHECK_THROWS_WITH_AS(cli::LinkAddress::parse("tcp:5000"), doctest::Contains("expected tcp:HOST:PORT"), Error);
  CHECK_THROWS_WITH_AS(cli::LinkAddress::parse("serial:COM3@fast"), doctest::Contains("baud rate 'fast'"), Error);
  CHECK_THROWS_WITH_AS(cli::LinkAddress::parse("serial:"), doctest::Contains("no port"), Error);
}

TEST_CASE("link: a pipe that pauses is waited on for the time asked, then read, then ends") {
  // glovepose record flushes what it wrote and says its health while the source pauses: a read
  // must come back within its wait (on Windows too, where a pipe cannot be polled).
  using std::chrono::milliseconds;
  WrittenPipe pipe;
  cli::ByteSource source(pipe.path());
  std::uint8_t buffer[16];
  const auto start = std::chrono::steady_clock::now();
  CHECK(source.read(buffer, sizeof buffer, milliseconds(100)) == cli::ByteSource::kNothingYet);
  const auto waited = std::chrono::steady_clock::now() - start;
  CHECK(waited >= milliseconds(90));
  CHECK(waited < milliseconds(2000));
  pipe.write("abc");
  CHECK(source.read(buffer, sizeof buffer, milliseconds(2000)) == 3);
  CHECK(std::string(buffer, buffer + 3) == "abc");
  pipe.close();
  CHECK(source.read(buffer, sizeof buffer, milliseconds(2000)) == 0);  // the writer is gone: the end
}

TEST_CASE("link: a TCP device that drops its connection is reconnected, the frames sent meanwhile counted lost") {
  LoopbackListener listener;
  tcp::acceptor& acceptor = listener.acceptor;
  boost::asio::io_context& io = listener.io;
  Device dev;
  std::set<std::uint32_t> sent;
  std::thread device([&] {
    for (int connection = 0; connection < 3; ++connection) {
      tcp::socket s(io);
      acceptor.accept(s);
      boost::asio::write(s, boost::asio::buffer(dev.hello(1000000 + kCycleUs * dev.next)));
      for (int i = 0; i < 40; ++i) {
        const Bytes f = dev.reading();
        sent.insert(dev.next - 1);
        boost::asio::write(s, boost::asio::buffer(f));
      }
      for (int i = 0; i < 5; ++i) dev.reading();  // sent while the link is down: never arrive
      std::this_thread::sleep_for(std::chrono::milliseconds(30));
    }
  });
  cli::GloveLink link(listener.address(), quick());
  const std::vector<std::uint32_t> got = read_until(link, 120);
  device.join();
  CHECK(got == std::vector<std::uint32_t>(sent.begin(), sent.end()));
  CHECK(link.events().connections == 3);
  CHECK(link.counts().lost == 10);  // the 5 frames of each of the two outages between the readings
  CHECK(link.counts().restarts == 0);
  CHECK(link.unidentified() == 0);
  REQUIRE(link.identity());
  CHECK(link.identity()->describe() == "glove 'glauser2019' (serial 77, 1 cells, 0 rows)");
}

TEST_CASE("link: a TCP device that reconnects as another glove is an error") {
  LoopbackListener listener;
  tcp::acceptor& acceptor = listener.acceptor;
  boost::asio::io_context& io = listener.io;
  Device dev;
  std::thread device([&] {
    for (int connection = 0; connection < 2; ++connection) {
      tcp::socket s(io);
      acceptor.accept(s);
      dev.serial = connection == 0 ? 77 : 78;
      boost::system::error_code e;
      boost::asio::write(s, boost::asio::buffer(dev.hello(1000000 + kCycleUs * dev.next)), e);
      for (int i = 0; i < 10 && !e; ++i) boost::asio::write(s, boost::asio::buffer(dev.reading()), e);
      if (connection == 1) std::this_thread::sleep_for(std::chrono::milliseconds(300));
    }
  });
  cli::GloveLink link(listener.address(), quick());
  CHECK_THROWS_WITH_AS(read_until(link, 100), doctest::Contains("serial 78"), Error);
  device.join();
}

TEST_CASE("link: for a service, another glove's frames are dropped and the glove's resume when it is back") {
  LoopbackListener listener;
  tcp::acceptor& acceptor = listener.acceptor;
  boost::asio::io_context& io = listener.io;
  Device dev;
  std::vector<std::uint32_t> sent_by_77;
  std::thread device([&] {
    for (int connection = 0; connection < 3; ++connection) {  // the glove, another glove, the glove again
      tcp::socket s(io);
      acceptor.accept(s);
      dev.serial = connection == 1 ? 78 : 77;
      boost::system::error_code e;
      boost::asio::write(s, boost::asio::buffer(dev.hello(1000000 + kCycleUs * dev.next)), e);
      for (int i = 0; i < 10 && !e; ++i) {
        if (dev.serial == 77) sent_by_77.push_back(dev.next);
        boost::asio::write(s, boost::asio::buffer(dev.reading()), e);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(connection == 2 ? 1500 : 100));
    }
  });
  cli::GloveLink link(listener.address(), quick(), std::nullopt, cli::GloveLink::OtherGlove::Refuse);
  const std::vector<std::uint32_t> got = read_until(link, 20);
  device.join();
  CHECK(got == sent_by_77);  // every reading of glove 77, none of 78's
  CHECK(link.refused() == 1);
  CHECK(link.last_refused().find("serial 78") != std::string::npos);
  CHECK(link.unidentified() == 11);  // 78's Hello and readings
}

TEST_CASE("link: a connection that goes silent is taken as lost and reopened") {
  LoopbackListener listener;
  tcp::acceptor& acceptor = listener.acceptor;
  boost::asio::io_context& io = listener.io;
  Device dev;
  std::thread device([&] {
    tcp::socket hung(io);
    acceptor.accept(hung);
    boost::asio::write(hung, boost::asio::buffer(dev.hello(1000000)));
    for (int i = 0; i < 10; ++i) boost::asio::write(hung, boost::asio::buffer(dev.reading()));
    tcp::socket fresh(io);  // the first stays open and says nothing: the link must give it up
    acceptor.accept(fresh);
    boost::asio::write(fresh, boost::asio::buffer(dev.hello(1000000 + kCycleUs * dev.next)));
    for (int i = 0; i < 10; ++i) boost::asio::write(fresh, boost::asio::buffer(dev.reading()));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  });
  cli::GloveLink link(listener.address(), quick());
  const std::vector<std::uint32_t> got = read_until(link, 20);
  device.join();
  CHECK(got.size() == 20);
  CHECK(link.events().connections == 2);
  CHECK(link.events().last_problem.find("nothing for 500 ms") != std::string::npos);
}

TEST_CASE("link: UDP datagrams left out are counted lost, and before a Hello nothing is used") {
  boost::asio::io_context io;
  udp::socket probe(io, udp::endpoint(boost::asio::ip::make_address("127.0.0.1"), 0));
  const unsigned port = probe.local_endpoint().port();
  probe.close();
  cli::GloveLink glove("udp:127.0.0.1:" + std::to_string(port), quick());
  udp::socket sender(io, udp::v4());
  const udp::endpoint to(boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port));
  Device dev;
  std::vector<std::uint32_t> sent;
  std::thread device([&] {
    for (int i = 0; i < 5; ++i) sender.send_to(boost::asio::buffer(dev.reading()), to);  // before any Hello: not used
    sender.send_to(boost::asio::buffer(dev.hello(1000000 + kCycleUs * dev.next)), to);
    for (int i = 0; i < 200; ++i) {
      const Bytes f = dev.reading();
      if (i % 17 == 3) continue;  // left out
      sent.push_back(dev.next - 1);
      sender.send_to(boost::asio::buffer(f), to);
      if (i % 20 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  const std::vector<std::uint32_t> got = read_until(glove, 188);
  device.join();
  CHECK(got == sent);
  CHECK(glove.unidentified() == 5);
  CHECK(glove.counts().lost == 12);
}
