/* glovepose_stream.h: a client of glovepose serve's engine stream (docs/pose_stream.md, version 1)
 * in C99, in one header, for engines and tools that take poses from the service instead of linking
 * the library.
 *
 * In exactly one C or C++ file, define GLOVEPOSE_STREAM_IMPLEMENTATION before including it:
 *
 *     #define GLOVEPOSE_STREAM_IMPLEMENTATION
 *     #include "glovepose_stream.h"
 *
 * POSIX (under -std=c99, define _POSIX_C_SOURCE 200112L first: getaddrinfo, poll) and Windows
 * (link ws2_32; Vista or later: WSAPoll). A connection is one socket, read by one thread; connecting may
 * block (set-up), reading waits at most the time it is given and never allocates.
 *
 *     gp_stream stream;
 *     gp_stream_pose pose;
 *     if (gp_stream_connect(&stream, "127.0.0.1", 7650) != GP_STREAM_POSE) ...
 *     while (gp_stream_read(&stream, &pose, 100) == GP_STREAM_POSE) use(pose.angles);
 *     gp_stream_close(&stream);
 */
#ifndef GLOVEPOSE_STREAM_H
#define GLOVEPOSE_STREAM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define GP_STREAM_MESSAGE_BYTES 248 /* one pose on the stream */
#define GP_STREAM_ANGLES 25         /* joint angles per pose */

/* One pose, as the service sent it. */
typedef struct gp_stream_pose {
  int hand;            /* 0 right, 1 left (GLOVEPOSE_HAND_RIGHT, GLOVEPOSE_HAND_LEFT of the C ABI) */
  uint32_t flags;      /* the pose's PoseFlag bits (include/glovepose/pose.hpp) */
  uint64_t sequence;   /* poses the estimator has made, this one included: a gap is poses missed */
  double stream_time;  /* the pose's time on the glove's clock, s */
  double host_time;    /* that moment on the host's monotonic clock, s */
  double published;    /* when the service sent it, on the same clock, s */
  double angles[GP_STREAM_ANGLES]; /* radians, in the order of hand::kDofs */
} gp_stream_pose;

typedef enum gp_stream_status {
  GP_STREAM_POSE = 0,        /* a pose was read (gp_stream_connect: connected) */
  GP_STREAM_NONE = 1,        /* no whole pose arrived within the wait */
  GP_STREAM_CLOSED = 2,      /* the service closed the connection */
  GP_STREAM_BAD_MESSAGE = 3, /* a message's magic, version, count or CRC is wrong: the client lost its place; reconnect */
  GP_STREAM_ERROR = 4        /* the socket failed (or could not connect) */
} gp_stream_status;

/* A connection. Its fields are the implementation's. */
typedef struct gp_stream {
  intptr_t socket;
  size_t have;
  unsigned char buffer[GP_STREAM_MESSAGE_BYTES];
} gp_stream;

/* Decodes one message of GP_STREAM_MESSAGE_BYTES bytes: GP_STREAM_POSE or GP_STREAM_BAD_MESSAGE. */
gp_stream_status gp_stream_decode(const unsigned char* message, gp_stream_pose* out);

/* Connects to the service's engine stream at host:port (TCP): GP_STREAM_POSE when connected, else
 * GP_STREAM_ERROR (the stream is then closed). */
gp_stream_status gp_stream_connect(gp_stream* stream, const char* host, unsigned short port);

/* The next pose, waiting at most wait_ms milliseconds (0: only what has arrived; -1: until one
 * comes or the connection ends). */
gp_stream_status gp_stream_read(gp_stream* stream, gp_stream_pose* out, int wait_ms);

/* The newest pose that has arrived, without waiting: every whole message waiting is read and the
 * last one kept (a game loop's call once per frame). GP_STREAM_NONE when none has arrived. */
gp_stream_status gp_stream_read_latest(gp_stream* stream, gp_stream_pose* out);

/* Closes the connection (again: nothing). */
void gp_stream_close(gp_stream* stream);

#ifdef __cplusplus
}
#endif

#endif /* GLOVEPOSE_STREAM_H */

#ifdef GLOVEPOSE_STREAM_IMPLEMENTATION
#ifndef GLOVEPOSE_STREAM_IMPLEMENTED
#define GLOVEPOSE_STREAM_IMPLEMENTED

#include <stdio.h>
#include <string.h>

#ifdef _WIN32
#  include <winsock2.h>
#  include <ws2tcpip.h>
typedef SOCKET gp_stream_socket_;
#  define GP_STREAM_NO_SOCKET_ ((intptr_t)INVALID_SOCKET)
#else
#  include <errno.h>
#  include <netdb.h>
#  include <netinet/in.h>
#  include <netinet/tcp.h>
#  include <poll.h>
#  include <sys/socket.h>
#  include <unistd.h>
typedef int gp_stream_socket_;
#  define GP_STREAM_NO_SOCKET_ ((intptr_t)-1)
#endif

static uint64_t gp_stream_le_(const unsigned char* p, int bytes) {
  uint64_t v = 0;
  int i;
  for (i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

static double gp_stream_f64_(const unsigned char* p) {
  const uint64_t bits = gp_stream_le_(p, 8);
  double v;
  memcpy(&v, &bits, sizeof v);
  return v;
}

/* CRC-32 as zlib computes it (reflected polynomial 0xEDB88320, initial and final value all ones). */
static uint32_t gp_stream_crc32_(const unsigned char* p, size_t size) {
  uint32_t crc = 0xFFFFFFFFu;
  size_t i;
  int bit;
  for (i = 0; i < size; ++i) {
    crc ^= p[i];
    for (bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

gp_stream_status gp_stream_decode(const unsigned char* m, gp_stream_pose* out) {
  int d;
  if (m[0] != 'G' || m[1] != 'H' || m[2] != 1 || m[3] > 1 || gp_stream_le_(m + 40, 2) != GP_STREAM_ANGLES) return GP_STREAM_BAD_MESSAGE;
  if ((uint32_t)gp_stream_le_(m + 244, 4) != gp_stream_crc32_(m, 244)) return GP_STREAM_BAD_MESSAGE;
  out->hand = m[3];
  out->flags = (uint32_t)gp_stream_le_(m + 4, 4);
  out->sequence = gp_stream_le_(m + 8, 8);
  out->stream_time = gp_stream_f64_(m + 16);
  out->host_time = gp_stream_f64_(m + 24);
  out->published = gp_stream_f64_(m + 32);
  for (d = 0; d < GP_STREAM_ANGLES; ++d) out->angles[d] = gp_stream_f64_(m + 44 + 8 * d);
  return GP_STREAM_POSE;
}

static void gp_stream_close_socket_(intptr_t s) {
#ifdef _WIN32
  closesocket((gp_stream_socket_)s);
  WSACleanup(); /* one per WSAStartup of gp_stream_connect */
#else
  close((gp_stream_socket_)s);
#endif
}

gp_stream_status gp_stream_connect(gp_stream* stream, const char* host, unsigned short port) {
  struct addrinfo hints, *found = NULL, *a;
  char service[8];
  int yes = 1;
#ifdef _WIN32
  WSADATA wsa;
  if (WSAStartup(MAKEWORD(2, 2), &wsa) != 0) return GP_STREAM_ERROR;
#endif
  stream->socket = GP_STREAM_NO_SOCKET_;
  stream->have = 0;
  memset(&hints, 0, sizeof hints);
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_protocol = IPPROTO_TCP;
  snprintf(service, sizeof service, "%u", (unsigned)port);
  if (getaddrinfo(host, service, &hints, &found) != 0) {
#ifdef _WIN32
    WSACleanup();
#endif
    return GP_STREAM_ERROR;
  }
  for (a = found; a != NULL; a = a->ai_next) {
    const gp_stream_socket_ s = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if ((intptr_t)s == GP_STREAM_NO_SOCKET_) continue;
    if (connect(s, a->ai_addr, (int)a->ai_addrlen) == 0) {
      stream->socket = (intptr_t)s;
      break;
    }
#ifdef _WIN32
    closesocket(s);
#else
    close(s);
#endif
  }
  freeaddrinfo(found);
  if (stream->socket == GP_STREAM_NO_SOCKET_) {
#ifdef _WIN32
    WSACleanup();
#endif
    return GP_STREAM_ERROR;
  }
  /* Only the service sends; this keeps a client's rare writes (none) from waiting. */
  setsockopt((gp_stream_socket_)stream->socket, IPPROTO_TCP, TCP_NODELAY, (const char*)&yes, sizeof yes);
  return GP_STREAM_POSE;
}

/* Waits up to wait_ms for bytes: 1 readable, 0 not yet, -1 failed. */
static int gp_stream_wait_(gp_stream* stream, int wait_ms) {
#ifdef _WIN32
  WSAPOLLFD p;
  p.fd = (SOCKET)stream->socket;
  p.events = POLLRDNORM;
  p.revents = 0;
  {
    const int n = WSAPoll(&p, 1, wait_ms);
    return n < 0 ? -1 : n > 0;
  }
#else
  struct pollfd p;
  int n;
  p.fd = (int)stream->socket;
  p.events = POLLIN;
  p.revents = 0;
  do n = poll(&p, 1, wait_ms);
  while (n < 0 && errno == EINTR);
  return n < 0 ? -1 : n > 0;
#endif
}

gp_stream_status gp_stream_read(gp_stream* stream, gp_stream_pose* out, int wait_ms) {
  if (stream->socket == GP_STREAM_NO_SOCKET_) return GP_STREAM_CLOSED;
  while (stream->have < GP_STREAM_MESSAGE_BYTES) {
    long got;
    const int ready = gp_stream_wait_(stream, wait_ms);
    if (ready < 0) return GP_STREAM_ERROR;
    if (ready == 0) return GP_STREAM_NONE;
    got = (long)recv((gp_stream_socket_)stream->socket, (char*)stream->buffer + stream->have, (int)(GP_STREAM_MESSAGE_BYTES - stream->have), 0);
    if (got == 0) return GP_STREAM_CLOSED;
#ifndef _WIN32
    if (got < 0 && errno == EINTR) continue;
#endif
    if (got < 0) return GP_STREAM_ERROR;
    stream->have += (size_t)got;
  }
  stream->have = 0;
  return gp_stream_decode(stream->buffer, out);
}

gp_stream_status gp_stream_read_latest(gp_stream* stream, gp_stream_pose* out) {
  gp_stream_status newest = GP_STREAM_NONE;
  for (;;) {
    const gp_stream_status s = gp_stream_read(stream, out, 0);
    if (s == GP_STREAM_NONE) return newest;
    if (s != GP_STREAM_POSE) return s;
    newest = GP_STREAM_POSE;
  }
}

void gp_stream_close(gp_stream* stream) {
  if (stream->socket != GP_STREAM_NO_SOCKET_) gp_stream_close_socket_(stream->socket);
  stream->socket = GP_STREAM_NO_SOCKET_;
  stream->have = 0;
}

#endif /* GLOVEPOSE_STREAM_IMPLEMENTED */
#endif /* GLOVEPOSE_STREAM_IMPLEMENTATION */
