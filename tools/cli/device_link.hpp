// A glove's byte link as the user names it, read with a time-out and reopened with back-off when it
// goes away (a cable pulled, a device reset, a pty closed): serial ports, TCP and UDP on Boost.Asio,
// which does them on Linux and Windows alike; files and stdin as plain reads to their end.
//   -                    stdin, to its end
//   serial:PORT[@BAUD]   a serial port (/dev/ttyACM0, COM3), 8N1, 115200 baud unless told; reopened
//   tcp:HOST:PORT        a device that serves its stream over TCP (a glove on Wi-Fi); reconnected
//   udp:PORT, udp:ADDRESS:PORT   datagrams sent to this port (on this local address; all by default)
//   PATH                 a terminal (a pty, a serial device) as serial:PATH; else a file or named
//                        pipe, to its end
#pragma once

#include <glovepose/config.hpp>
#include <glovepose/core/span.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ip/udp.hpp>
#include <boost/asio/serial_port.hpp>

#include "byte_link.hpp"

#ifndef _WIN32
#  include <sys/stat.h>
#endif

namespace glovepose::cli {

/// The help text of an option naming a link.
inline constexpr const char* kLinkHelp =
    "the glove's link: '-' for stdin, a file or named pipe, a pty or serial port (its path, or serial:PORT[@BAUD], "
    "115200 baud unless told), tcp:HOST:PORT, or udp:[ADDRESS:]PORT; a port or socket that goes away is reopened";

/// Opens `port` at `name` (/dev/ttyACM0, COM3) as 8N1 at `baud`, no flow control; `e` says why not.
inline void open_serial_port(boost::asio::serial_port& port, const std::string& name, unsigned baud, boost::system::error_code& e) {
  port.open(name, e);
  if (!e) port.set_option(boost::asio::serial_port::baud_rate(baud), e);
  if (!e) port.set_option(boost::asio::serial_port::character_size(8), e);
  if (!e) port.set_option(boost::asio::serial_port::parity(boost::asio::serial_port::parity::none), e);
  if (!e) port.set_option(boost::asio::serial_port::stop_bits(boost::asio::serial_port::stop_bits::one), e);
  if (!e) port.set_option(boost::asio::serial_port::flow_control(boost::asio::serial_port::flow_control::none), e);
}

/// Where a link's bytes come from, parsed from the user's text.
struct LinkAddress {
  enum class Kind { Stdin, File, Serial, Tcp, Udp };
  Kind kind = Kind::Stdin;
  std::string text;   ///< as the user wrote it, for messages
  std::string where;  ///< the path, the port's name or the host
  unsigned port = 0;
  unsigned baud = 115200;

  /// Whether the link is reopened when it goes away (files and stdin end instead).
  bool reconnects() const { return kind == Kind::Serial || kind == Kind::Tcp || kind == Kind::Udp; }

  static LinkAddress parse(const std::string& text) {
    LinkAddress a;
    a.text = text;
    const auto number = [&](const std::string& digits, unsigned low, unsigned high, const char* what) {
      std::size_t used = 0;
      unsigned long value = 0;
      try {
        value = std::stoul(digits, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (digits.empty() || used != digits.size() || value < low || value > high)
        throw Error("link '" + text + "': " + what + " '" + digits + "', expected a whole number from " + std::to_string(low) + " to " +
                    std::to_string(high));
      return static_cast<unsigned>(value);
    };
    const auto starts = [&](const char* prefix) { return text.rfind(prefix, 0) == 0; };
    if (text == "-") return a;
    if (starts("serial:")) {
      a.kind = Kind::Serial;
      a.where = text.substr(7);
      const std::size_t at = a.where.rfind('@');
      if (at != std::string::npos) {
        a.baud = number(a.where.substr(at + 1), 50, 4000000, "baud rate");
        a.where.resize(at);
      }
      if (a.where.empty()) throw Error("link '" + text + "': no port, expected serial:PORT[@BAUD] (serial:/dev/ttyACM0, serial:COM3@115200)");
      return a;
    }
    if (starts("tcp:") || starts("udp:")) {
      a.kind = starts("tcp:") ? Kind::Tcp : Kind::Udp;
      const std::string rest = text.substr(4);
      const std::size_t colon = rest.rfind(':');
      a.where = colon == std::string::npos ? std::string() : rest.substr(0, colon);
      a.port = number(colon == std::string::npos ? rest : rest.substr(colon + 1), 1, 65535, "port");
      if (a.kind == Kind::Tcp && a.where.empty()) throw Error("link '" + text + "': no host, expected tcp:HOST:PORT");
      if (a.kind == Kind::Udp && a.where.empty()) a.where = "0.0.0.0";
      return a;
    }
    a.where = text;
    a.kind = is_terminal(text) ? Kind::Serial : Kind::File;
    return a;
  }

 private:
  static bool is_terminal(const std::string& path) {
#ifdef _WIN32
    (void)path;
    return false;
#else
    struct stat info {};
    if (::stat(path.c_str(), &info) != 0 || !S_ISCHR(info.st_mode)) return false;
    const int fd = ::open(path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return false;
    const bool terminal = ::isatty(fd) != 0;
    ::close(fd);
    return terminal;
#endif
  }
};

/// How a lost link is reopened: the first retry after `first`, each next one after twice as long, up
/// to `longest`; a connected link that sends nothing for `silence` is taken as lost (a hung port).
struct LinkTiming {
  std::chrono::milliseconds first{50}, longest{1000}, silence{2000};
};

/// A link's life so far.
struct LinkEvents {
  std::uint64_t connections = 0;     ///< opened (the first time included)
  std::uint64_t losses = 0;          ///< went away (error, end, silence)
  std::uint64_t failed_opens = 0;    ///< attempts to reopen that failed
  double down_seconds = 0;           ///< time spent without a connection after the first
  std::string last_problem;          ///< why it was last lost or not reopened
};

/// A glove's byte link: read() waits up to a time for bytes, and reopens a lost link meanwhile.
class DeviceLink {
 public:
  explicit DeviceLink(const LinkAddress& address, LinkTiming timing = {}) : address_(address), timing_(timing) {
    if (!address_.reconnects()) {
      file_ = std::make_unique<ByteSource>(address_.kind == LinkAddress::Kind::Stdin ? std::string("-") : address_.where);
      ++events_.connections;
      return;
    }
    // The first open must work (a wrong name is the user's to fix); later ones are retried.
    std::string problem;
    if (!open(problem)) throw Error("link '" + address_.text + "': cannot open it: " + problem);
  }
  DeviceLink(const DeviceLink&) = delete;
  DeviceLink& operator=(const DeviceLink&) = delete;

  /// Up to `size` bytes, waiting at most `wait` for some (a file or stdin waits until it has some):
  /// the count, 0 when none came (the link may be down and being reopened: connected() says), -1
  /// at the end of a file or stdin (a reconnecting link never ends).
  long read(std::uint8_t* data, std::size_t size, std::chrono::milliseconds wait) {
    if (file_) {
      const long n = file_->read(data, size, wait);
      return n == 0 ? -1 : std::max(n, 0L);  // the end; else the bytes, or none yet
    }
    const auto now = Clock::now();
    if (!connected()) {
      if (now < next_attempt_) {
        std::this_thread::sleep_for(std::min<Clock::duration>(wait, next_attempt_ - now));
        return 0;
      }
      std::string problem;
      if (!open(problem)) {
        ++events_.failed_opens;
        events_.last_problem = problem;
        retry_after_ = std::min(retry_after_ * 2, timing_.longest);
        next_attempt_ = Clock::now() + retry_after_;
        return 0;
      }
    }
    std::size_t got = 0;
    boost::system::error_code failure;
    bool done = false;
    const auto on_read = [&](const boost::system::error_code& e, std::size_t n) {
      failure = e;
      got = n;
      done = true;
    };
    const auto buffer = boost::asio::buffer(data, size);
    if (serial_) serial_->async_read_some(buffer, on_read);
    if (tcp_) tcp_->async_read_some(buffer, on_read);
    if (udp_) udp_->async_receive_from(buffer, sender_, on_read);
    io_.restart();
    io_.run_for(wait);
    if (!done) {  // nothing within the wait: cancel the read and let its handler run
      boost::system::error_code ignored;
      if (serial_) serial_->cancel(ignored);
      if (tcp_) tcp_->cancel(ignored);
      if (udp_) udp_->cancel(ignored);
      io_.restart();
      io_.run();
      if (failure == boost::asio::error::operation_aborted) failure = {};
    }
    const auto end = Clock::now();
    if (failure) {
      lose(failure == boost::asio::error::eof ? std::string("the other end closed it") : failure.message());
      return 0;
    }
    if (got > 0) {
      last_bytes_ = end;
    } else if (address_.kind != LinkAddress::Kind::Udp && end - last_bytes_ > timing_.silence) {
      // A datagram link has no connection to lose; a port or socket that went silent may be hung.
      lose("nothing for " + std::to_string(timing_.silence.count()) + " ms");
    }
    return static_cast<long>(got);
  }

  bool connected() const { return file_ || serial_ || tcp_ || udp_; }
  const LinkEvents& events() const { return events_; }
  const LinkAddress& address() const { return address_; }

 private:
  using Clock = std::chrono::steady_clock;

  bool open(std::string& problem) {
    boost::system::error_code e;
    using Kind = LinkAddress::Kind;
    if (address_.kind == Kind::Serial) {
      auto port = std::make_unique<boost::asio::serial_port>(io_);
      open_serial_port(*port, address_.where, address_.baud, e);
      if (!e) serial_ = std::move(port);
    } else if (address_.kind == Kind::Tcp) {
      boost::asio::ip::tcp::resolver resolver(io_);
      const auto endpoints = resolver.resolve(address_.where, std::to_string(address_.port), e);
      if (!e) {
        auto socket = std::make_unique<boost::asio::ip::tcp::socket>(io_);
        for (const auto& endpoint : endpoints) {
          socket->close(e);
          socket->connect(endpoint.endpoint(), e);
          if (!e) break;
        }
        if (!e) tcp_ = std::move(socket);
      }
    } else {
      const auto local = boost::asio::ip::make_address(address_.where, e);
      if (!e) {
        auto socket = std::make_unique<boost::asio::ip::udp::socket>(io_);
        socket->open(local.is_v6() ? boost::asio::ip::udp::v6() : boost::asio::ip::udp::v4(), e);
        if (!e) socket->bind(boost::asio::ip::udp::endpoint(local, static_cast<unsigned short>(address_.port)), e);
        if (!e) udp_ = std::move(socket);
      }
    }
    if (e) {
      problem = e.message();
      return false;
    }
    ++events_.connections;
    if (down_since_) events_.down_seconds += std::chrono::duration<double>(Clock::now() - *down_since_).count();
    down_since_.reset();
    retry_after_ = timing_.first;
    last_bytes_ = Clock::now();
    return true;
  }

  void lose(std::string why) {
    ++events_.losses;
    events_.last_problem = std::move(why);
    serial_.reset();
    tcp_.reset();
    udp_.reset();
    down_since_ = Clock::now();
    next_attempt_ = Clock::now() + retry_after_;
  }

  LinkAddress address_;
  LinkTiming timing_;
  LinkEvents events_;
  boost::asio::io_context io_;
  std::unique_ptr<ByteSource> file_;
  std::unique_ptr<boost::asio::serial_port> serial_;
  std::unique_ptr<boost::asio::ip::tcp::socket> tcp_;
  std::unique_ptr<boost::asio::ip::udp::socket> udp_;
  boost::asio::ip::udp::endpoint sender_;
  std::chrono::milliseconds retry_after_ = timing_.first;
  Clock::time_point next_attempt_{}, last_bytes_{};
  std::optional<Clock::time_point> down_since_;
};

/// Datagrams to one HOST:PORT (resolved once), sent without waiting: a device's frames on UDP, OSC.
class UdpSender {
 public:
  /// `what` names the target in messages ("--osc '127.0.0.1:9000'").
  UdpSender(const std::string& host, unsigned port, const std::string& what) : socket_(io_) {
    boost::system::error_code e;
    boost::asio::ip::udp::resolver resolver(io_);
    const auto endpoints = resolver.resolve(boost::asio::ip::udp::v4(), host, std::to_string(port), e);
    if (e || endpoints.empty()) throw Error(what + ": cannot resolve '" + host + "': " + e.message());
    to_ = endpoints.begin()->endpoint();
    socket_.open(to_.protocol(), e);
    if (!e) socket_.non_blocking(true, e);
    if (e) throw Error(what + ": cannot open a UDP socket: " + e.message());
  }

  /// Sends one datagram; false when it could not be sent. One nobody receives is sent: a sender on
  /// UDP does not know or care whether anyone listens.
  bool send(const std::uint8_t* data, std::size_t size) {
    boost::system::error_code e;
    socket_.send_to(boost::asio::buffer(data, size), to_, 0, e);
    return !e || e == boost::asio::error::connection_refused;
  }

 private:
  boost::asio::io_context io_;
  boost::asio::ip::udp::socket socket_;
  boost::asio::ip::udp::endpoint to_;
};

/// Where a device's frames go (glovepose simulate --stream): '-' for stdout or a path (a file, a named
/// pipe, a pty or serial port: byte_link.hpp's ByteSink), or udp:HOST:PORT, one frame per datagram.
class FrameSink {
 public:
  explicit FrameSink(const std::string& target) : target_(target) {
    if (target.rfind("udp:", 0) != 0) {
      bytes_ = std::make_unique<ByteSink>(target);
      return;
    }
    const LinkAddress a = LinkAddress::parse(target);
    udp_ = std::make_unique<UdpSender>(a.where, a.port, "stream target '" + target + "'");
  }

  /// Whether the link has no connection (datagrams): a reader may start at any moment, so the
  /// device says its Hello again every second.
  bool datagrams() const { return udp_ != nullptr; }

  /// Sends one whole frame; throws Error when a byte stream's other end is gone or a datagram
  /// cannot be sent.
  void send(core::Span<const std::uint8_t> frame) {
    if (bytes_) {
      bytes_->write(frame.data(), frame.size());
    } else if (!udp_->send(frame.data(), frame.size())) {
      throw Error("stream target '" + target_ + "': cannot send a datagram");
    }
  }

 private:
  std::string target_;
  std::unique_ptr<ByteSink> bytes_;
  std::unique_ptr<UdpSender> udp_;
};

}  // namespace glovepose::cli
