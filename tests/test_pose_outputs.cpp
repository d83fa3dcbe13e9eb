// glovepose serve's outputs (tools/cli/pose_outputs.hpp, opengloves_output.hpp) on loopback
// sockets, where every platform has them: natively, under Wine for Windows and under qemu-user for
// ARM64 (tests/python/test_serve.py drives the whole service on Linux). Messages are read back by
// the layouts docs/pose_stream.md gives, byte by byte.
#include <doctest/doctest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cli/opengloves_output.hpp"
#include "cli/pose_outputs.hpp"

#ifndef _WIN32
#  include <fcntl.h>
#  include <stdlib.h>
#  include <termios.h>
#  include <unistd.h>
#endif

namespace {

using namespace glovepose;
using boost::asio::ip::tcp;
using boost::asio::ip::udp;

// A little-endian field of a message (docs/pose_stream.md, "The engine stream").
std::uint64_t little_field(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
double little_f64(const std::uint8_t* p) {
  const std::uint64_t bits = little_field(p, 8);
  double v = 0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

// Reads what has arrived on `socket` (non-blocking) onto `bytes`.
void take_waiting(tcp::socket& socket, std::vector<std::uint8_t>& bytes) {
  std::array<std::uint8_t, 65536> chunk{};
  for (;;) {
    boost::system::error_code e;
    const std::size_t got = socket.read_some(boost::asio::buffer(chunk), e);
    if (e || got == 0) return;
    bytes.insert(bytes.end(), chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(got));
  }
}

}  // namespace

TEST_CASE("serve's engine stream: reading clients get every pose whole, a stalled one misses some without holding them up") {
  cli::EngineServer server(0);
  boost::asio::io_context io;
  std::vector<tcp::socket> readers;
  const tcp::endpoint at(boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(server.port()));
  for (int k = 0; k < 3; ++k) {
    readers.emplace_back(io);
    readers.back().connect(at);
    readers.back().non_blocking(true);
  }
  tcp::socket stalled(io);
  stalled.open(tcp::v4());
  stalled.set_option(boost::asio::socket_base::receive_buffer_size(2048));  // fills after a few messages, never read
  stalled.connect(at);
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (server.clients() < 4 && std::chrono::steady_clock::now() < give_up) {
    server.accept();
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  REQUIRE(server.clients() == 4);

  constexpr int kPoses = 4000;  // 1 MB: far more than a stalled client's socket buffers hold
  std::vector<std::vector<std::uint8_t>> got(readers.size());
  cli::PoseMessage message;
  Pose pose;
  std::vector<hand::Angles> sent(kPoses);  // as computed here (the compiler may fuse a multiply-add differently in another expression)
  for (int i = 0; i < kPoses; ++i) {
    pose.sequence = static_cast<std::uint64_t>(i) + 1;
    pose.timestamp = i / 60.0;
    pose.flags = static_cast<std::uint32_t>(i % 3);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) pose.angles[d] = 0.001 * i - 0.01 * static_cast<double>(d);
    sent[static_cast<std::size_t>(i)] = pose.angles;
    message.encode(pose, hand::Handedness::Left, 100.0 + i / 60.0, 200.0 + i);
    server.publish(message);
    for (std::size_t k = 0; k < readers.size(); ++k) take_waiting(readers[k], got[k]);
  }
  const auto drained = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (std::chrono::steady_clock::now() < drained) {
    bool all = true;
    for (std::size_t k = 0; k < readers.size(); ++k) {
      take_waiting(readers[k], got[k]);
      all = all && got[k].size() >= kPoses * cli::PoseMessage::kBytes;
    }
    if (all) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }

  for (std::size_t k = 0; k < readers.size(); ++k) {
    INFO("reader " << k);
    REQUIRE(got[k].size() == kPoses * cli::PoseMessage::kBytes);
    for (int i = 0; i < kPoses; ++i) {
      const std::uint8_t* m = got[k].data() + static_cast<std::size_t>(i) * cli::PoseMessage::kBytes;
      REQUIRE(m[0] == 'G');
      REQUIRE(m[1] == 'H');
      REQUIRE(m[2] == 1);
      REQUIRE(m[3] == 1);  // left: GLOVEPOSE_HAND_LEFT
      REQUIRE(little_field(m + 4, 4) == static_cast<std::uint64_t>(i % 3));
      REQUIRE(little_field(m + 8, 8) == static_cast<std::uint64_t>(i) + 1);
      REQUIRE(little_f64(m + 16) == i / 60.0);
      REQUIRE(little_f64(m + 24) == 100.0 + i / 60.0);
      REQUIRE(little_f64(m + 32) == 200.0 + i);
      REQUIRE(little_field(m + 40, 2) == hand::kDofCount);
      for (std::size_t d = 0; d < hand::kDofCount; ++d) REQUIRE(little_f64(m + 44 + 8 * d) == sent[static_cast<std::size_t>(i)][d]);
      REQUIRE(little_field(m + 244, 4) == device::crc32(m, 244));
    }
  }
  CHECK(server.counts().skipped > 0);  // the stalled client missed poses
  CHECK(server.counts().sent >= 3u * kPoses);
}

TEST_CASE("serve's OpenGloves line: the documented example, keys in order, and the long form's joints") {
  hand::Angles angles{};
  for (const char* name : {"index_base_flexion", "index_middle_flexion", "index_tip_flexion"}) {
    const std::size_t d = hand::dof_from_name(name);
    angles[d] = 0.5 * hand::kDofs[d].max;
  }
  cli::OpenGlovesLine line(4095, false);
  line.encode(hand::finger_curls(angles));
  // docs/pose_stream.md, "OpenGloves": the example line.
  CHECK(std::string(line.data(), line.size()) == "A0B2048C0D0E0(AB)2048(BB)2048(CB)2048(DB)2048(EB)2048P0\n");

  cli::OpenGlovesLine joints(1023, true);
  joints.encode(hand::finger_curls(angles));
  CHECK(std::string(joints.data(), joints.size()) ==
        "A0B512C0D0E0(AB)512(BB)512(CB)512(DB)512(EB)512P0(AAA)0(AAB)0(AAC)0(BAA)0(BAB)512(BAC)512(BAD)512(CAA)0(CAB)0(CAC)0(CAD)0"
        "(DAA)0(DAB)0(DAC)0(DAD)0(EAA)0(EAB)0(EAC)0(EAD)0\n");

  // The longest lines are the documented 74 and 233 bytes: every value at 4 digits (a metacarpal's at 1: it is 0),
  // every gesture on.
  hand::Angles bent{};
  for (std::size_t d = 0; d < hand::kDofCount; ++d) bent[d] = hand::kDofs[d].max;
  cli::OpenGlovesLine full(4095, true), short_form(4095, false);
  full.encode(hand::finger_curls(bent));
  short_form.encode(hand::finger_curls(bent));
  // (DB): the ring's abduction limit, 0.30 rad, is 17.2 of the 20 degrees of a full splay: round((0.859 + 1) / 2 x 4095).
  CHECK(std::string(short_form.data(), short_form.size()) ==
        "A4095B4095C4095D4095E4095(AB)4095(BB)4095(CB)4095(DB)3807(EB)4095P4095ILM\n");
  CHECK(short_form.size() == 74);
  CHECK(full.size() == 233);

  // The gestures' documented rules at their edges: grab past a mean curl of half of the four
  // fingers, pinch past half of the thumb's and index's, the trigger past half of the index's, its
  // value (curl - 0.5) x 2.
  const auto line_for = [](std::initializer_list<std::pair<const char*, double>> shares) {
    hand::Angles a{};
    for (const auto& [name, share] : shares) a[hand::dof_from_name(name)] = share * hand::kDofs[hand::dof_from_name(name)].max;
    cli::OpenGlovesLine l(1000, false);
    l.encode(hand::finger_curls(a));
    return std::string(l.data(), l.size());
  };
  CHECK(line_for({{"index_base_flexion", 0.75}, {"index_middle_flexion", 0.75}, {"index_tip_flexion", 0.75}}) ==
        "A0B750C0D0E0(AB)500(BB)500(CB)500(DB)500(EB)500P500I\n");
  CHECK(line_for({{"thumb_base_flexion", 0.6}, {"thumb_middle_flexion", 0.6}, {"thumb_tip_flexion", 0.6}, {"index_base_flexion", 0.45},
                  {"index_middle_flexion", 0.45}, {"index_tip_flexion", 0.45}}) == "A600B450C0D0E0(AB)500(BB)500(CB)500(DB)500(EB)500P0M\n");
  std::initializer_list<std::pair<const char*, double>> fingers = {
      {"index_base_flexion", 0.6}, {"index_middle_flexion", 0.6}, {"index_tip_flexion", 0.6},  {"middle_base_flexion", 0.6},
      {"middle_middle_flexion", 0.6}, {"middle_tip_flexion", 0.6}, {"ring_base_flexion", 0.6}, {"ring_middle_flexion", 0.6},
      {"ring_tip_flexion", 0.6},   {"pinky_base_flexion", 0.6},   {"pinky_middle_flexion", 0.6}, {"pinky_tip_flexion", 0.6}};
  CHECK(line_for(fingers) == "A0B600C600D600E600(AB)500(BB)500(CB)500(DB)500(EB)500P200IL\n");
  CHECK_THROWS_AS(cli::OpenGlovesLine(0, false), Error);
}

namespace {

// A float32 field of an OpenGloves pipe message at byte `at` (docs/pose_stream.md, "OpenGloves":
// little-endian, no padding).
float pipe_float(const std::uint8_t* message, std::size_t at) {
  const auto bits = static_cast<std::uint32_t>(little_field(message + at, 4));
  float v = 0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

// Checks a pipe message against the curls it was made of, field by field as documented:
// flexion[5][4] at 0, splay[5] at 80, the joystick at 100 and 104, eight buttons at 108, the trigger at 116.
void check_pipe_message(const std::uint8_t* message, const hand::FingerCurls& curls) {
  for (std::size_t f = 0; f < 5; ++f) {
    for (std::size_t j = 0; j < 4; ++j) CHECK(pipe_float(message, 4 * (4 * f + j)) == static_cast<float>(curls.joints[f][j]));
    CHECK(pipe_float(message, 80 + 4 * f) == static_cast<float>(curls.splay[f]));
  }
  CHECK(pipe_float(message, 100) == 0.0f);
  CHECK(pipe_float(message, 104) == 0.0f);
  // The booleans: joystick button, trigger button, A, B, grab, pinch, menu, calibrate; the gestures'
  // documented rules (docs/pose_stream.md) computed here.
  const double index = curls.curl[1];
  const bool trigger = index > 0.5;
  const bool grab = (curls.curl[1] + curls.curl[2] + curls.curl[3] + curls.curl[4]) / 4.0 > 0.5;
  const bool pinch = (curls.curl[0] + curls.curl[1]) / 2.0 > 0.5;
  const std::uint8_t expected[8] = {0, trigger, 0, 0, grab, pinch, 0, 0};
  for (std::size_t b = 0; b < 8; ++b) CHECK(message[108 + b] == expected[b]);
  CHECK(pipe_float(message, 116) == static_cast<float>(trigger ? 2.0 * index - 1.0 : 0.0));
}

// A pose whose index and middle bend by `k` thousandths of their limits and whose index splays by
// k/2000: each pose of a run its own.
hand::FingerCurls numbered_curls(long k) {
  hand::Angles angles{};
  const double share = static_cast<double>(k % 1000) / 1000.0;
  for (const char* name : {"index_base_flexion", "index_middle_flexion", "middle_tip_flexion"}) {
    const std::size_t d = hand::dof_from_name(name);
    angles[d] = share * hand::kDofs[d].max;
  }
  angles[hand::dof_from_name("index_base_abduction")] = 0.5 * share * hand::kFullSplay;
  angles[hand::dof_from_name("thumb_tip_flexion")] = 0.7 * hand::kDofs[hand::dof_from_name("thumb_tip_flexion")].max;
  return hand::finger_curls(angles);
}

}  // namespace

TEST_CASE("serve's OpenGloves pipe message: the SteamVR driver's 120 bytes, decoded as documented") {
  cli::OpenGlovesPipeMessage message;
  static_assert(cli::OpenGlovesPipeMessage::size() == 120, "NamedPipeInputDataVersion::v2 is 120 bytes");
  for (const long k : {0L, 1L, 500L, 900L, 999L}) {  // 900 and 999: the trigger on
    const hand::FingerCurls curls = numbered_curls(k);
    message.encode(curls);
    check_pipe_message(reinterpret_cast<const std::uint8_t*>(message.data()), curls);
  }
  hand::Angles bent{};  // every gesture on
  for (std::size_t d = 0; d < hand::kDofCount; ++d) bent[d] = hand::kDofs[d].max;
  message.encode(hand::finger_curls(bent));
  check_pipe_message(reinterpret_cast<const std::uint8_t*>(message.data()), hand::finger_curls(bent));
  CHECK(message.data()[112] == 1);
  // The thumb's unused 4th joint repeats its tip, as in the long OpenGloves line.
  message.encode(numbered_curls(3));
  CHECK(pipe_float(reinterpret_cast<const std::uint8_t*>(message.data()), 12) == doctest::Approx(0.7).epsilon(1e-6));
  CHECK(pipe_float(reinterpret_cast<const std::uint8_t*>(message.data()), 8) == doctest::Approx(0.7).epsilon(1e-6));
#ifndef _WIN32
  CHECK_THROWS_WITH_AS(cli::OpenGlovesPort("pipe:glove"), doctest::Contains("needs Windows"), Error);
#endif
}

TEST_CASE("serve's VRChat parameters: OSC floats by the documented names, at most 20 sets a second") {
  boost::asio::io_context io;
  udp::socket receiver(io, udp::endpoint(boost::asio::ip::make_address("127.0.0.1"), 0));
  receiver.non_blocking(true);
  cli::AvatarParameters avatar("127.0.0.1:" + std::to_string(receiver.local_endpoint().port()), "left");
  hand::Angles angles{};
  angles[hand::dof_from_name("ring_middle_flexion")] = 1.0;
  angles[hand::dof_from_name("pinky_base_abduction")] = -0.1;
  const hand::FingerCurls curls = hand::finger_curls(angles);
  avatar.publish(curls, 10.0);
  avatar.publish(curls, 10.02);  // too soon: not sent
  avatar.publish(curls, 10.051);

  std::vector<std::pair<std::string, float>> messages;
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (messages.size() < 20 && std::chrono::steady_clock::now() < give_up) {
    std::array<char, 512> datagram{};
    boost::system::error_code e;
    const std::size_t n = receiver.receive(boost::asio::buffer(datagram), 0, e);
    if (e) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    // OSC 1.0: the address, NUL-padded to 4 bytes; ",f" padded; a big-endian float32.
    const std::string address(datagram.data());
    const std::size_t tags = (address.size() + 4) / 4 * 4;
    REQUIRE(n == tags + 4 + 4);
    REQUIRE(std::string(datagram.data() + tags) == ",f");
    std::uint32_t bits = 0;
    for (int i = 0; i < 4; ++i) bits = (bits << 8) | static_cast<std::uint8_t>(datagram[tags + 4 + static_cast<std::size_t>(i)]);
    float value = 0;
    std::memcpy(&value, &bits, sizeof value);
    messages.emplace_back(address, value);
  }
  REQUIRE(messages.size() == 20);  // two sets of ten
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  std::array<char, 512> extra{};
  boost::system::error_code none;
  receiver.receive(boost::asio::buffer(extra), 0, none);
  CHECK(none);  // nothing more: the set at 10.02 s was not sent
  const char* const fingers[] = {"Thumb", "Index", "Middle", "Ring", "Pinky"};
  for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
    CHECK(messages[2 * f].first == std::string("/avatar/parameters/Left") + fingers[f] + "Curl");
    CHECK(messages[2 * f].second == static_cast<float>(curls.curl[f]));
    CHECK(messages[2 * f + 1].first == std::string("/avatar/parameters/Left") + fingers[f] + "Splay");
    CHECK(messages[2 * f + 1].second == static_cast<float>(curls.splay[f]));
  }
  CHECK(messages[6].second == doctest::Approx(1.0 / 2.0 / 3.0));  // ring: middle flexion 1 rad of 2 rad, one joint of three
  CHECK(messages[9].second == doctest::Approx(-0.1 / (20.0 * 3.14159265358979323846 / 180.0)));  // pinky splay
}

#ifndef _WIN32
namespace {

// A pseudo-terminal pair as a test's stand-in for a driver's serial port: the test holds `master`
// (the driver's side), the output writes to the slave's path; closing master is the port going away.
struct TestPty {
  int master = -1;
  std::string slave;
  TestPty() {
    master = ::posix_openpt(O_RDWR | O_NOCTTY);
    REQUIRE(master >= 0);
    REQUIRE(::grantpt(master) == 0);
    REQUIRE(::unlockpt(master) == 0);
    slave = ::ptsname(master);
    termios mode{};
    REQUIRE(::tcgetattr(master, &mode) == 0);
    ::cfmakeraw(&mode);
    REQUIRE(::tcsetattr(master, TCSANOW, &mode) == 0);
    ::fcntl(master, F_SETFL, ::fcntl(master, F_GETFL) | O_NONBLOCK);
  }
  ~TestPty() { close(); }
  void close() {
    if (master >= 0) ::close(master);
    master = -1;
  }
};

// Every byte waiting on `fd` (non-blocking) onto `text`.
void read_waiting(int fd, std::string& text) {
  std::array<char, 4096> chunk{};
  for (;;) {
    const ssize_t n = ::read(fd, chunk.data(), chunk.size());
    if (n <= 0) return;
    text.append(chunk.data(), static_cast<std::size_t>(n));
  }
}

// The numbers of the lines "L<number>\n" in `text`, which must hold whole lines only.
std::vector<long> line_numbers(const std::string& text) {
  std::vector<long> numbers;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = text.find('\n', at);
    REQUIRE(end != std::string::npos);  // no line cut off
    REQUIRE(text[at] == 'L');
    numbers.push_back(std::stol(text.substr(at + 1, end - at - 1)));
    at = end + 1;
  }
  return numbers;
}

// The test's line number `k`, always 8 bytes.
std::string numbered_line(long k) {
  std::string digits = std::to_string(k % 1000000);
  return "L" + std::string(6 - digits.size(), '0') + digits + "\n";
}

std::string test_path(const char* name) {
  return (std::filesystem::temp_directory_path() / (std::string(name) + "-" + std::to_string(::getpid()))).string();
}

}  // namespace

TEST_CASE("serve's OpenGloves pty: lines no driver reads are discarded, so a driver that opens it late reads fresh ones") {
  const std::string link = test_path("glovepose-og-pty");
  cli::OpenGlovesPort port("pty:" + link);
  long offered = 0;
  const auto start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - start < std::chrono::milliseconds(1300)) {  // no driver for 1.3 s
    const std::string line = numbered_line(offered++);
    port.send(line.data(), line.size());
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  port.finish();
  const cli::OpenGlovesCounts& c = port.counts();
  CHECK(c.sent + c.skipped + c.failed == static_cast<std::uint64_t>(offered));
  CHECK(c.failed == 0);
  CHECK(c.unread > 0);

  const int driver = ::open(link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
  REQUIRE(driver >= 0);
  std::string text;
  read_waiting(driver, text);
  ::close(driver);
  const std::vector<long> numbers = line_numbers(text);
  REQUIRE(!numbers.empty());
  for (std::size_t i = 1; i < numbers.size(); ++i) CHECK(numbers[i] > numbers[i - 1]);
  CHECK(numbers.back() >= offered - 2);  // the newest line (the last one may have been skipped)
  // What the driver found: the lines of at most the last kUnreadLimit (and those the count of
  // discarded lines missed while they were still on their way into the pty), not the whole wait.
  CHECK(numbers.size() <= c.sent - c.unread);
  CHECK(numbers.size() < static_cast<std::size_t>(offered) / 2);
  MESSAGE(offered << " lines offered over 1.3 s with no driver: " << c.sent << " sent, " << c.unread << " discarded unread, "
                  << numbers.size() << " read by a driver that opened the pty then");
}

TEST_CASE("serve's OpenGloves serial port: lost when its other end goes, reopened when it comes back, every line counted") {
  const std::string link = test_path("glovepose-og-serial");
  std::filesystem::remove(link);
  auto first = std::make_unique<TestPty>();
  std::filesystem::create_symlink(first->slave, link);
  cli::OpenGlovesPort port("serial:" + link, cli::LinkTiming{std::chrono::milliseconds(5), std::chrono::milliseconds(20), {}});
  long offered = 0;
  std::string before, after;
  const auto offer = [&](int lines, TestPty* reader, std::string& text) {
    for (int i = 0; i < lines; ++i) {
      const std::string line = numbered_line(offered++);
      port.send(line.data(), line.size());
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      if (reader) read_waiting(reader->master, text);
    }
  };
  offer(50, first.get(), before);
  port.finish();
  read_waiting(first->master, before);
  first->close();  // the driver's end goes away
  offer(50, nullptr, before);
  CHECK(port.events().losses == 1);
  CHECK(port.events().connections == 1);

  TestPty second;  // and comes back under the same name
  std::filesystem::remove(link);
  std::filesystem::create_symlink(second.slave, link);
  offer(100, &second, after);
  port.finish();
  read_waiting(second.master, after);
  std::filesystem::remove(link);

  const cli::OpenGlovesCounts& c = port.counts();
  CHECK(c.sent + c.skipped + c.failed == static_cast<std::uint64_t>(offered));
  CHECK(port.events().connections == 2);
  CHECK(port.events().failed_opens > 0);  // while the name pointed nowhere
  const std::vector<long> a = line_numbers(before), b = line_numbers(after);
  CHECK(a.size() + b.size() == c.sent);  // every line counted sent was read whole
  CHECK(c.failed >= 49);                 // the lines offered while it was gone
  REQUIRE(!a.empty());
  REQUIRE(!b.empty());
  CHECK(a.back() < 50);
  CHECK(b.front() >= 100);
}

TEST_CASE("serve's OpenGloves serial port: one that takes nothing for a second is taken as hung and reopened") {
  TestPty pty;  // never read: the port's buffers fill and a write waits
  cli::OpenGlovesPort port("serial:" + pty.slave, cli::LinkTiming{std::chrono::milliseconds(5), std::chrono::milliseconds(20), {}});
  long offered = 0;
  const std::string line(200, 'x');
  const auto start = std::chrono::steady_clock::now();
  while (port.events().connections < 2 && std::chrono::steady_clock::now() - start < std::chrono::seconds(10)) {
    port.send(line.data(), line.size());
    ++offered;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  CHECK(port.events().losses == 1);
  CHECK(port.events().connections == 2);
  CHECK(port.events().last_problem.find("not taken in 1000 ms") != std::string::npos);
  port.finish();
  const cli::OpenGlovesCounts& c = port.counts();
  CHECK(c.sent + c.skipped + c.failed == static_cast<std::uint64_t>(offered));
  CHECK(c.skipped > 0);
  CHECK(c.failed >= 1);
}
#endif

#ifdef _WIN32
namespace {

// The driver's end of OpenGloves' pipe, as LucidVR's SteamVR driver makes it (a message pipe, one
// instance, duplex, buffers of one message, read one message at a time): served once, read until
// `stop`, then disconnected and closed, as the driver does when SteamVR quits.
class DriverPipe {
 public:
  explicit DriverPipe(const std::string& name) {
    handle_ = ::CreateNamedPipeA(name.c_str(), PIPE_ACCESS_DUPLEX, PIPE_TYPE_MESSAGE | PIPE_READMODE_MESSAGE | PIPE_WAIT, 1, 120, 120, 5, nullptr);
    REQUIRE(handle_ != INVALID_HANDLE_VALUE);
    thread_ = std::thread([this] {
      const bool connected = ::ConnectNamedPipe(handle_, nullptr) || ::GetLastError() == ERROR_PIPE_CONNECTED;
      std::array<std::uint8_t, 256> buffer{};
      while (connected && !stop_) {
        DWORD got = 0;
        if (!::ReadFile(handle_, buffer.data(), static_cast<DWORD>(buffer.size()), &got, nullptr)) break;
        if (!stop_) messages_.emplace_back(buffer.begin(), buffer.begin() + got);
      }
      ::DisconnectNamedPipe(handle_);
      ::CloseHandle(handle_);
      done_ = true;
    });
  }
  DriverPipe(const DriverPipe&) = delete;
  DriverPipe& operator=(const DriverPipe&) = delete;
  ~DriverPipe() {
    if (thread_.joinable()) thread_.join();
  }
  // Stops reading at the next message (`wake` sends it) and returns the messages read before.
  template <typename Wake>
  std::vector<std::vector<std::uint8_t>> quit(Wake wake) {
    stop_ = true;
    while (!done_) wake();  // a message it reads ends its read
    thread_.join();
    return std::move(messages_);
  }

 private:
  std::atomic<bool> stop_{false}, done_{false};
  HANDLE handle_ = INVALID_HANDLE_VALUE;
  std::thread thread_;
  std::vector<std::vector<std::uint8_t>> messages_;
};

}  // namespace

TEST_CASE("serve's OpenGloves named pipe: messages as the SteamVR driver reads them, written once it serves, again after it comes back") {
  const std::string name = "\\\\.\\pipe\\glovepose-opengloves-" + std::to_string(::GetCurrentProcessId());
  cli::OpenGlovesPort port("pipe:" + name, cli::LinkTiming{std::chrono::milliseconds(5), std::chrono::milliseconds(20), {}});
  CHECK(port.takes_messages());
  CHECK(port.events().connections == 0);  // no driver yet
  cli::OpenGlovesPipeMessage message;
  long offered = 0;
  const auto offer = [&](int count) {
    for (int i = 0; i < count; ++i) {
      message.encode(numbered_curls(offered++));
      port.send(message.data(), message.size());
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  };
  offer(20);  // before the driver serves the pipe: failed
  CHECK(port.counts().failed >= 19);
  std::vector<std::vector<std::vector<std::uint8_t>>> runs;
  for (int run = 0; run < 2; ++run) {
    std::vector<std::vector<std::uint8_t>> read;
    {
      DriverPipe driver(name);  // SteamVR starts
      offer(200);
      read = driver.quit([&] { offer(1); });  // and quits
    }
    runs.push_back(std::move(read));
    offer(50);  // nobody serves the pipe: lost, then failed
  }
  port.finish();
  const cli::OpenGlovesCounts& c = port.counts();
  CHECK(c.sent + c.skipped + c.failed == static_cast<std::uint64_t>(offered));
  CHECK(port.events().connections == 2);
  CHECK(port.events().losses == 2);
  // Each driver read whole 120-byte messages, each an offered pose, in order, most of those offered.
  long last = -1;
  for (const auto& read : runs) {
    CHECK(read.size() >= 150);
    for (const auto& m : read) {
      REQUIRE(m.size() == 120);
      // The pose's number from the middle's tip (k/1000 of its limit), then the whole message.
      const long k = std::lround(pipe_float(m.data(), 4 * (4 * 2 + 3)) * 1000.0f);
      CHECK(k > last);
      last = k;
      check_pipe_message(m.data(), numbered_curls(k));
    }
  }
  MESSAGE(offered << " poses offered: " << c.sent << " sent, " << c.skipped << " skipped, " << c.failed << " failed; the two drivers read "
                  << runs[0].size() << " and " << runs[1].size());
}
#endif
