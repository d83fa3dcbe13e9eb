// A glove on a link (device_link.hpp): its bytes parsed into checked frames, its identity taken from
// the Hello it sends after every connection and checked on each reconnection, and its clock mapped
// onto the host's (device/device_clock.hpp).
#pragma once

#include <glovepose/device/device_clock.hpp>
#include <glovepose/device/frame_parser.hpp>
#include <glovepose/device/wire_format.hpp>

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "device_link.hpp"
#include "frame_feed.hpp"

namespace glovepose::cli {

/// Which glove a Hello says is on the link.
struct GloveIdentity {
  std::string glove_id;
  std::uint32_t serial = 0;
  int rows = 0, cells = 0;

  bool operator==(const GloveIdentity& o) const { return glove_id == o.glove_id && serial == o.serial && rows == o.rows && cells == o.cells; }
  bool operator!=(const GloveIdentity& o) const { return !(*this == o); }
  std::string describe() const {
    return "glove '" + glove_id + "' (serial " + std::to_string(serial) + ", " + std::to_string(cells) + " cells, " + std::to_string(rows) + " rows)";
  }
};

/// Seconds of the host's monotonic clock, the time base of mapped device times.
inline double host_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// A glove's frames from a link, with the link reopened when it goes away. On a link that
/// reconnects, each connection's frames count only after its Hello: those before it (the device
/// may have been replaced) are dropped and counted as unidentified. A Hello naming another glove than
/// the first one, or than `expected`, is an Error; or with OtherGlove::Refuse (a service that must
/// go on), that connection's frames are dropped (unidentified) until a Hello names the glove again.
class GloveLink {
 public:
  enum class OtherGlove { Error, Refuse };

  explicit GloveLink(const std::string& source, LinkTiming timing = {}, std::optional<GloveIdentity> expected = std::nullopt,
                     OtherGlove other = OtherGlove::Error)
      : link_(LinkAddress::parse(source), timing), identity_(std::move(expected)), other_(other), buffer_(1 << 16) {}

  /// Reads for at most `wait` (a file or stdin: until bytes come) and calls
  /// `use(const device::Frame&, double mapped, double arrived)` for each frame passed on, Hellos
  /// included: its device time mapped onto host_seconds(), and when its last byte was read. False
  /// once a file or stdin has ended.
  template <typename Use>
  bool poll(std::chrono::milliseconds wait, Use&& use) {
    const long n = link_.read(buffer_.data(), buffer_.size(), wait);
    if (link_.events().connections != connection_) {  // a new connection: its bytes start afresh
      parser_.finish();
      connection_ = link_.events().connections;
      identified_ = !link_.address().reconnects();
    }
    if (n < 0) {
      parser_.finish();
      return false;
    }
    const double arrived = host_seconds();
    feed_frames(parser_, buffer_.data(), static_cast<std::size_t>(n), [&](const device::Frame& f) {
      if (f.header.kind == device::FrameKind::Hello) check_hello(f);
      if (!identified_) {
        ++unidentified_;
        return;
      }
      clock_.add(f.header.device_time_us, arrived);
      use(f, clock_.to_host(f.header.device_time_us), arrived);
    });
    return true;
  }

  /// The glove the link carries, once a Hello said it (or as expected).
  const std::optional<GloveIdentity>& identity() const { return identity_; }
  const device::LinkCounts& counts() const { return parser_.counts(); }
  const LinkEvents& events() const { return link_.events(); }
  const device::DeviceClock& clock() const { return clock_; }
  /// Frames dropped because no Hello had yet named the glove on their connection.
  std::uint64_t unidentified() const { return unidentified_; }
  /// Hellos of another glove refused (OtherGlove::Refuse), and what the last one said.
  std::uint64_t refused() const { return refused_; }
  const std::string& last_refused() const { return last_refused_; }
  const LinkAddress& address() const { return link_.address(); }

 private:
  void check_hello(const device::Frame& f) {
    device::Hello hello;
    if (device::read_hello(f, hello) != Status::Ok) return;  // not identified: its frames stay dropped
    GloveIdentity said{std::string(hello.glove_id), hello.serial, hello.rows, hello.cells};
    if (identity_ && *identity_ != said) {
      const std::string problem = "link '" + link_.address().text + "': the device says it is " + said.describe() + ", but the link carried " +
                                  identity_->describe() + (connection_ > 1 ? " before it reconnected" : "") +
                                  "; another glove needs its own link";
      if (other_ == OtherGlove::Error) throw Error(problem);
      ++refused_;
      last_refused_ = problem;
      identified_ = false;  // this connection's frames are dropped, until the glove says its Hello again
      return;
    }
    identity_ = said;
    identified_ = true;
  }

  DeviceLink link_;
  std::optional<GloveIdentity> identity_;
  OtherGlove other_;
  std::string last_refused_;
  std::uint64_t refused_ = 0;
  device::FrameParser parser_;
  device::DeviceClock clock_;
  std::vector<std::uint8_t> buffer_;
  std::uint64_t connection_ = 0, unidentified_ = 0;
  bool identified_ = false;
};

/// The link's life as one line ("opened 3 times, 1.2 s down, 0 frames before a Hello").
inline std::string link_events_summary(const GloveLink& link) {
  const LinkEvents& e = link.events();
  char down[32];
  std::snprintf(down, sizeof down, "%.2f", e.down_seconds);
  return "opened " + std::to_string(e.connections) + (e.connections == 1 ? " time, " : " times, ") + down + " s down, " +
         std::to_string(link.unidentified()) + " frames dropped before a Hello named the glove";
}

}  // namespace glovepose::cli
