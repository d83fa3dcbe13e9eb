/* Prints the poses of glovepose serve's engine stream, one line each: the sequence, the stream time
 * and the 25 angles (%.9g, as `glovepose predict --raw` prints them), comma-separated.
 * Usage: glovepose_stream_print HOST PORT [COUNT]   (stops after COUNT poses, or when the stream
 * closes, goes wrong or is silent for 5 s, and says which on stderr). Exits 0 when it printed at
 * least one pose. */
#if !defined(_WIN32) && !defined(_POSIX_C_SOURCE)
#  define _POSIX_C_SOURCE 200112L /* getaddrinfo and poll under -std=c99 */
#endif
#define GLOVEPOSE_STREAM_IMPLEMENTATION
#include "glovepose_stream.h"

#include <stdio.h>
#include <stdlib.h>

int main(int argc, char** argv) {
  gp_stream stream;
  gp_stream_pose pose;
  gp_stream_status status = GP_STREAM_POSE;
  static const char* const why[] = {"", "no pose for 5 s", "closed by the service", "a bad message (lost its place)", "a socket error"};
  long count = argc > 3 ? atol(argv[3]) : -1, printed = 0;
  int port = argc > 2 ? atoi(argv[2]) : 0;
  if (argc < 3 || port < 1 || port > 65535) {
    fprintf(stderr, "usage: glovepose_stream_print HOST PORT [COUNT]\n");
    return 2;
  }
  if (gp_stream_connect(&stream, argv[1], (unsigned short)port) != GP_STREAM_POSE) {
    fprintf(stderr, "glovepose_stream_print: cannot connect to %s:%d\n", argv[1], port);
    return 1;
  }
  while ((count < 0 || printed < count) && (status = gp_stream_read(&stream, &pose, 5000)) == GP_STREAM_POSE) {
    int d;
    printf("%llu,%.9g", (unsigned long long)pose.sequence, pose.stream_time);
    for (d = 0; d < GP_STREAM_ANGLES; ++d) printf(",%.9g", pose.angles[d]);
    printf("\n");
    fflush(stdout);
    ++printed;
  }
  gp_stream_close(&stream);
  if (status != GP_STREAM_POSE) fprintf(stderr, "glovepose_stream_print: the stream ended: %s\n", why[status]);
  if (printed == 0) fprintf(stderr, "glovepose_stream_print: no pose from %s:%d\n", argv[1], port);
  return printed > 0 ? 0 : 1;
}
