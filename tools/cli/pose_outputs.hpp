// Where glovepose serve sends poses: the engine stream (docs/pose_stream.md) to any number of TCP
// clients on loopback, none of which can hold the others up, OSC messages over UDP, and VRChat's
// avatar parameters over OSC. All on Boost.Asio, non-blocking, with every buffer made before the
// first pose. (OpenGloves: opengloves_output.hpp.)
#pragma once

#include <glovepose/device/crc32.hpp>
#include <glovepose/device/wire_format.hpp>
#include <glovepose/hand/finger_curls.hpp>
#include <glovepose/hand/handedness.hpp>
#include <glovepose/pose.hpp>

#include <array>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>

#include "device_link.hpp"

namespace glovepose::cli {

/// One pose of the engine stream, laid out as docs/pose_stream.md says.
struct PoseMessage {
  static constexpr std::size_t kBytes = 248;
  static constexpr std::uint8_t kVersion = 1;
  std::array<std::uint8_t, kBytes> bytes{};

  /// `hand`: the side, coded as hand::Handedness (0 right, 1 left, as the C ABI's GLOVEPOSE_HAND_*); the pose's time is on the device's clock (s); `host_time`: that time
  /// on the host's monotonic clock; `published`: when it is sent (host clock).
  void encode(const Pose& pose, hand::Handedness hand, double host_time, double published) noexcept {
    std::uint8_t* p = bytes.data();
    p[0] = 'G';
    p[1] = 'H';
    p[2] = kVersion;
    p[3] = static_cast<std::uint8_t>(hand);
    device::wire::put_u32(p + 4, pose.flags);
    device::wire::put_u64(p + 8, pose.sequence);
    device::wire::put_f64(p + 16, pose.timestamp);
    device::wire::put_f64(p + 24, host_time);
    device::wire::put_f64(p + 32, published);
    device::wire::put_u16(p + 40, static_cast<std::uint16_t>(hand::kDofCount));
    device::wire::put_u16(p + 42, 0);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) device::wire::put_f64(p + 44 + 8 * d, pose.angles[d]);
    device::wire::put_u32(p + 244, device::crc32(p, 244));
  }
};

/// What the engine stream did.
struct EngineCounts {
  std::uint64_t clients = 0;   ///< connected so far
  std::uint64_t sent = 0;      ///< messages handed whole to a client's socket
  std::uint64_t skipped = 0;   ///< messages a client missed because it had not taken the previous ones
  std::uint64_t gone = 0;      ///< clients that closed or failed
};

/// The engine stream's server: TCP on a loopback port, each client sent every pose it can take. A
/// client that does not read (stalled, or slower than the glove) misses poses instead of holding up
/// the others: a message is written only to a client whose socket takes it now; one taken in part
/// is finished before that client gets another.
class EngineServer {
 public:
  /// The send buffer asked for each client (the system may double it, as Linux does).
  static constexpr int kBacklogBytes = 32768;

  explicit EngineServer(unsigned port, std::size_t most_clients = 32) : acceptor_(io_), most_(most_clients) {
    boost::system::error_code e;
    const boost::asio::ip::tcp::endpoint at(boost::asio::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port));
    acceptor_.open(at.protocol(), e);
    if (!e) acceptor_.set_option(boost::asio::socket_base::reuse_address(true), e);
    if (!e) acceptor_.bind(at, e);
    if (!e) acceptor_.listen(boost::asio::socket_base::max_listen_connections, e);
    if (!e) acceptor_.non_blocking(true, e);
    if (e) throw Error("engine stream: cannot listen on 127.0.0.1:" + std::to_string(port) + ": " + e.message());
    clients_.reserve(most_);
  }

  /// The port it listens on (the one asked for, or the system's choice for 0).
  unsigned port() const { return acceptor_.local_endpoint().port(); }

  /// Takes the clients that have connected since; beyond the most it serves, a client is closed.
  void accept() {
    for (;;) {
      boost::system::error_code e;
      boost::asio::ip::tcp::socket socket(io_);
      acceptor_.accept(socket, e);
      if (e) return;  // would block: no one waiting
      if (clients_.size() >= most_) continue;
      socket.non_blocking(true, e);
      if (!e) socket.set_option(boost::asio::ip::tcp::no_delay(true), e);
      // A client's backlog is bounded: about 2 s of poses at 60 Hz wait for it, then it misses poses.
      if (!e) socket.set_option(boost::asio::socket_base::send_buffer_size(kBacklogBytes), e);
      if (e) continue;
      clients_.push_back(Client{std::move(socket), {}, 0});
      ++counts_.clients;
    }
  }

  /// Sends `message` to every client that can take it now.
  void publish(const PoseMessage& message) {
    for (auto c = clients_.begin(); c != clients_.end();) {
      if (!finish(*c) || (c->left == 0 && !write(*c, message.bytes.data(), message.bytes.size()))) {
        ++counts_.gone;
        c = clients_.erase(c);
        continue;
      }
      ++c;
    }
  }

  std::size_t clients() const { return clients_.size(); }
  const EngineCounts& counts() const { return counts_; }

 private:
  struct Client {
    boost::asio::ip::tcp::socket socket;
    std::array<std::uint8_t, PoseMessage::kBytes> rest;  // the unsent end of a message taken in part
    std::size_t left;
  };

  // The rest of a message taken in part; false when the client is gone. A client still holding a
  // rest after this misses the new message.
  bool finish(Client& c) {
    if (c.left == 0) return true;
    std::size_t wrote = 0;
    if (!write_some(c, c.rest.data() + (PoseMessage::kBytes - c.left), c.left, wrote)) return false;
    c.left -= wrote;
    if (c.left > 0) ++counts_.skipped;
    return true;
  }

  bool write(Client& c, const std::uint8_t* data, std::size_t size) {
    std::size_t wrote = 0;
    if (!write_some(c, data, size, wrote)) return false;
    if (wrote == 0) {
      ++counts_.skipped;
    } else if (wrote < size) {
      std::memcpy(c.rest.data(), data, size);
      c.left = size - wrote;
      ++counts_.sent;
    } else {
      ++counts_.sent;
    }
    return true;
  }

  static bool write_some(Client& c, const std::uint8_t* data, std::size_t size, std::size_t& wrote) {
    boost::system::error_code e;
    wrote = c.socket.write_some(boost::asio::buffer(data, size), e);
    if (e == boost::asio::error::would_block || e == boost::asio::error::try_again) {
      wrote = 0;
      return true;
    }
    return !e;
  }

  boost::asio::io_context io_;
  boost::asio::ip::tcp::acceptor acceptor_;
  std::size_t most_;
  std::vector<Client> clients_;
  EngineCounts counts_;
};

/// OSC 1.0 messages over UDP (docs/pose_stream.md, "OSC"): big-endian arguments, each part padded
/// to 4 bytes. Hand-written rather than liblo's: Debian's liblo has no Windows build, and a message
/// of floats is a few lines.
class OscSender {
 public:
  /// `option` names the target in messages.
  explicit OscSender(const std::string& target, const std::string& option = "--osc") {
    const std::string what = option + " '" + target + "'";
    if (target.rfind("udp:", 0) == 0) throw Error(what + ": expected HOST:PORT (127.0.0.1:9000), without 'udp:'");
    const LinkAddress a = LinkAddress::parse("udp:" + target);
    if (a.where == "0.0.0.0") throw Error(what + ": no host, expected HOST:PORT (127.0.0.1:9000)");
    udp_ = std::make_unique<UdpSender>(a.where, a.port, what);
    message_.reserve(512);
  }

  /// Starts a message to `address` with `types` (OSC type tags after the ',': "f" float32, "i"
  /// int32, "h" int64, "d" float64).
  OscSender& begin(const std::string& address, const std::string& types) {
    message_.clear();
    text(address, "");
    text(",", types);
    return *this;
  }
  OscSender& f(float v) {
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    return big(bits, 4);
  }
  OscSender& d(double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    return big(bits, 8);
  }
  OscSender& h(std::int64_t v) { return big(static_cast<std::uint64_t>(v), 8); }

  /// Sends the message; a datagram nobody receives is not an error. Counts what could not be sent.
  void send() {
    failed_ += !udp_->send(message_.data(), message_.size());
    ++sent_;
  }

  std::uint64_t sent() const { return sent_; }
  std::uint64_t failed() const { return failed_; }

 private:
  OscSender& big(std::uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i) message_.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
  void text(const std::string& head, const std::string& rest) {  // head and rest, NUL-terminated, padded to a multiple of 4
    message_.insert(message_.end(), head.begin(), head.end());
    message_.insert(message_.end(), rest.begin(), rest.end());
    do message_.push_back(0);
    while (message_.size() % 4 != 0);
  }

  std::unique_ptr<UdpSender> udp_;
  std::vector<std::uint8_t> message_;
  std::uint64_t sent_ = 0, failed_ = 0;
};

/// A pose's curls and splays as VRChat avatar parameters (docs/pose_stream.md, "VRChat"): OSC
/// messages /avatar/parameters/<Hand><Finger>Curl (0 to 1) and ...Splay (-1 to 1), one float each,
/// at most once per kPeriod: VRChat applies parameters at its network rate, and more would only
/// fill its queue.
class AvatarParameters {
 public:
  static constexpr double kPeriod = 0.05;  ///< seconds: 20 updates a second

  /// `hand`: "left" or "right".
  AvatarParameters(const std::string& target, const std::string& hand) : osc_(target, "--vrchat") {
    const std::string side = hand == "left" ? "Left" : "Right";
    static constexpr const char* kFinger[hand::kFingerCount] = {"Thumb", "Index", "Middle", "Ring", "Pinky"};
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      curl_[f] = "/avatar/parameters/" + side + kFinger[f] + "Curl";
      splay_[f] = "/avatar/parameters/" + side + kFinger[f] + "Splay";
    }
  }

  /// Sends `curls` unless the last were sent less than kPeriod before `now` (seconds, any clock).
  void publish(const hand::FingerCurls& curls, double now) {
    if (now - last_ < kPeriod) return;
    last_ = now;
    for (std::size_t f = 0; f < hand::kFingerCount; ++f) {
      osc_.begin(curl_[f], "f").f(static_cast<float>(curls.curl[f])).send();
      osc_.begin(splay_[f], "f").f(static_cast<float>(curls.splay[f])).send();
    }
  }

  const OscSender& osc() const { return osc_; }

 private:
  OscSender osc_;
  std::array<std::string, hand::kFingerCount> curl_, splay_;
  double last_ = -1e300;
};

}  // namespace glovepose::cli
