// The few socket calls glovepose view's loopback server makes, on POSIX and on Windows (Winsock 2),
// so that the tool builds and serves the same page on both.
#pragma once

#include <glovepose/config.hpp>

#ifdef _WIN32
#  include <winsock2.h>
#  include <ws2tcpip.h>
#else
#  include <arpa/inet.h>
#  include <netinet/in.h>
#  include <poll.h>
#  include <sys/socket.h>
#  include <unistd.h>
#endif

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>

namespace glovepose::cli {

#ifdef _WIN32
using Socket = SOCKET;
inline constexpr Socket kNoSocket = INVALID_SOCKET;
#else
using Socket = int;
inline constexpr Socket kNoSocket = -1;
#endif

/// @brief Winsock's start and end (WSAStartup, WSACleanup) around a server's life; nothing on POSIX.
class SocketLibrary {
 public:
  SocketLibrary() {
#ifdef _WIN32
    WSADATA data;
    if (WSAStartup(MAKEWORD(2, 2), &data) != 0) throw Error("cannot start Winsock 2.2, expected a Windows with TCP/IP");
#endif
  }
  ~SocketLibrary() {
#ifdef _WIN32
    WSACleanup();
#endif
  }
  SocketLibrary(const SocketLibrary&) = delete;
  SocketLibrary& operator=(const SocketLibrary&) = delete;
};

inline void close_socket(Socket s) noexcept {
#ifdef _WIN32
  (void)::closesocket(s);
#else
  (void)::close(s);
#endif
}

/// @brief Whether `s` has a connection or data to read within `milliseconds`.
inline bool wait_readable(Socket s, int milliseconds) noexcept {
#ifdef _WIN32
  WSAPOLLFD waiting{s, POLLRDNORM, 0};
  return ::WSAPoll(&waiting, 1, milliseconds) > 0;
#else
  pollfd waiting{s, POLLIN, 0};
  return ::poll(&waiting, 1, milliseconds) > 0;
#endif
}

/// @brief Sends all of `data`; stops quietly when the peer went away (no SIGPIPE on Linux).
inline void send_all(Socket s, const std::string& data) noexcept {
  std::size_t sent = 0;
  while (sent < data.size()) {
#ifdef _WIN32
    const int n = ::send(s, data.data() + sent, static_cast<int>(data.size() - sent), 0);
#else
    const ssize_t n = ::send(s, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
#endif
    if (n <= 0) return;
    sent += static_cast<std::size_t>(n);
  }
}

/// @brief Up to `size` bytes received from `s` (empty when the peer closed or failed).
inline std::string receive_some(Socket s, std::size_t size) {
  std::string buffer(size, '\0');
#ifdef _WIN32
  const int n = ::recv(s, buffer.data(), static_cast<int>(size), 0);
#else
  const ssize_t n = ::recv(s, buffer.data(), size, 0);
#endif
  buffer.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return buffer;
}

/// @brief A listening socket on 127.0.0.1:port (0: any free port) and the port it got.
inline std::pair<Socket, int> listen_on_loopback(int port) {
  const Socket s = ::socket(AF_INET, SOCK_STREAM, 0);
  if (s == kNoSocket) throw Error("cannot create a socket");
#ifndef _WIN32
  // A restarted view may take its port back at once. (On Windows SO_REUSEADDR would let another
  // program take a port in use: its default already refuses that and frees ports promptly.)
  const int yes = 1;
  (void)::setsockopt(s, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
#endif
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  if (::bind(s, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(s, 16) != 0) {
    close_socket(s);
    throw Error("cannot listen on 127.0.0.1:" + std::to_string(port) + ", expected a free port (--port)");
  }
  socklen_t length = sizeof address;
  (void)::getsockname(s, reinterpret_cast<sockaddr*>(&address), &length);
  return {s, ntohs(address.sin_port)};
}

}  // namespace glovepose::cli
