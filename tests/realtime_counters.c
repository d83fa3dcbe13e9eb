/* Counts what GLOVEPOSE_REALTIME forbids, where it would leave the code under test (glibc only):
 * heap allocations, locks and system calls (realtime_counters.h).
 *
 * Defines malloc, calloc, realloc and the aligned allocators, counting each call and forwarding to
 * glibc's __libc_* functions. The dynamic linker binds the program's and its shared libraries'
 * calls (libstdc++'s operator new, Eigen's aligned_malloc, libglovepose_c) to these, so every heap
 * allocation is seen. Defines the pthread mutex, condition variable and read-write lock calls
 * (std::mutex and std::condition_variable are built on them) and the C library's wrappers of the
 * common system calls the same way, forwarding to the next definition (dlsym RTLD_NEXT). Clocks are
 * not counted: clock_gettime is served by the vDSO, without entering the kernel. */
#define _GNU_SOURCE
#include "realtime_counters.h"

#include <dlfcn.h>
#include <errno.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <stdarg.h>
#include <stddef.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

extern void* __libc_malloc(size_t size);
extern void* __libc_calloc(size_t count, size_t size);
extern void* __libc_realloc(void* p, size_t size);
extern void* __libc_memalign(size_t alignment, size_t size);

static volatile unsigned long allocations = 0;

void* malloc(size_t size) {
  ++allocations;
  return __libc_malloc(size);
}
void* calloc(size_t count, size_t size) {
  ++allocations;
  return __libc_calloc(count, size);
}
void* realloc(void* p, size_t size) {
  ++allocations;
  return __libc_realloc(p, size);
}
void* aligned_alloc(size_t alignment, size_t size) {
  ++allocations;
  return __libc_memalign(alignment, size);
}
void* memalign(size_t alignment, size_t size) {
  ++allocations;
  return __libc_memalign(alignment, size);
}
int posix_memalign(void** out, size_t alignment, size_t size) {
  void* p;
  ++allocations;
  p = __libc_memalign(alignment, size);
  if (p == NULL) return ENOMEM;
  *out = p;
  return 0;
}

static volatile unsigned long locks = 0, system_calls = 0;

/* The next definition of `name` (glibc's) as `type`, a function pointer type, looked up once
 * (POSIX's way to store dlsym's answer in a function pointer). */
#define NEXT(type, name) \
  static type next_fn = NULL; \
  if (next_fn == NULL) *(void**)(&next_fn) = dlsym(RTLD_NEXT, name)
typedef int (*mutex_call)(pthread_mutex_t*);
typedef int (*cond_wait_call)(pthread_cond_t*, pthread_mutex_t*);
typedef int (*cond_timedwait_call)(pthread_cond_t*, pthread_mutex_t*, const struct timespec*);
typedef int (*cond_call)(pthread_cond_t*);
typedef int (*rwlock_call)(pthread_rwlock_t*);
typedef ssize_t (*write_call)(int, const void*, size_t);
typedef ssize_t (*read_call)(int, void*, size_t);
typedef int (*close_call)(int);
typedef int (*nanosleep_call)(const struct timespec*, struct timespec*);
typedef int (*clock_nanosleep_call)(clockid_t, int, const struct timespec*, struct timespec*);
typedef int (*usleep_call)(useconds_t);
typedef int (*yield_call)(void);
typedef void* (*mmap_call)(void*, size_t, int, int, int, off_t);
typedef int (*munmap_call)(void*, size_t);
typedef int (*poll_call)(struct pollfd*, nfds_t, int);
typedef long (*syscall_call)(long, ...);

int pthread_mutex_lock(pthread_mutex_t* m) {
  NEXT(mutex_call, "pthread_mutex_lock");
  ++locks;
  return next_fn(m);
}
int pthread_mutex_trylock(pthread_mutex_t* m) {
  NEXT(mutex_call, "pthread_mutex_trylock");
  ++locks;
  return next_fn(m);
}
int pthread_cond_wait(pthread_cond_t* c, pthread_mutex_t* m) {
  NEXT(cond_wait_call, "pthread_cond_wait");
  ++locks;
  return next_fn(c, m);
}
int pthread_cond_timedwait(pthread_cond_t* c, pthread_mutex_t* m, const struct timespec* t) {
  NEXT(cond_timedwait_call, "pthread_cond_timedwait");
  ++locks;
  return next_fn(c, m, t);
}
int pthread_cond_signal(pthread_cond_t* c) {
  NEXT(cond_call, "pthread_cond_signal");
  ++locks;
  return next_fn(c);
}
int pthread_cond_broadcast(pthread_cond_t* c) {
  NEXT(cond_call, "pthread_cond_broadcast");
  ++locks;
  return next_fn(c);
}
int pthread_rwlock_rdlock(pthread_rwlock_t* l) {
  NEXT(rwlock_call, "pthread_rwlock_rdlock");
  ++locks;
  return next_fn(l);
}
int pthread_rwlock_wrlock(pthread_rwlock_t* l) {
  NEXT(rwlock_call, "pthread_rwlock_wrlock");
  ++locks;
  return next_fn(l);
}

ssize_t write(int fd, const void* data, size_t size) {
  NEXT(write_call, "write");
  ++system_calls;
  return next_fn(fd, data, size);
}
ssize_t read(int fd, void* data, size_t size) {
  NEXT(read_call, "read");
  ++system_calls;
  return next_fn(fd, data, size);
}
int close(int fd) {
  NEXT(close_call, "close");
  ++system_calls;
  return next_fn(fd);
}
int nanosleep(const struct timespec* t, struct timespec* left) {
  NEXT(nanosleep_call, "nanosleep");
  ++system_calls;
  return next_fn(t, left);
}
int clock_nanosleep(clockid_t clock, int flags, const struct timespec* t, struct timespec* left) {
  NEXT(clock_nanosleep_call, "clock_nanosleep");
  ++system_calls;
  return next_fn(clock, flags, t, left);
}
int usleep(useconds_t us) {
  NEXT(usleep_call, "usleep");
  ++system_calls;
  return next_fn(us);
}
int sched_yield(void) {
  NEXT(yield_call, "sched_yield");
  ++system_calls;
  return next_fn();
}
void* mmap(void* at, size_t size, int protection, int flags, int fd, off_t offset) {
  NEXT(mmap_call, "mmap");
  ++system_calls;
  return next_fn(at, size, protection, flags, fd, offset);
}
int munmap(void* at, size_t size) {
  NEXT(munmap_call, "munmap");
  ++system_calls;
  return next_fn(at, size);
}
int poll(struct pollfd* fds, nfds_t count, int timeout) {
  NEXT(poll_call, "poll");
  ++system_calls;
  return next_fn(fds, count, timeout);
}
long syscall(long number, ...) { /* futex and the like, called by number */
  va_list args;
  long a[6];
  int i;
  NEXT(syscall_call, "syscall");
  va_start(args, number);
  for (i = 0; i < 6; ++i) a[i] = va_arg(args, long);
  va_end(args);
  ++system_calls;
  return next_fn(number, a[0], a[1], a[2], a[3], a[4], a[5]);
}

unsigned long realtime_allocations(void) { return allocations; }
unsigned long realtime_locks(void) { return locks; }
unsigned long realtime_system_calls(void) { return system_calls; }
