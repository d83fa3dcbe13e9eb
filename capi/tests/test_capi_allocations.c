/* The per-frame calls of the C ABI allocate nothing, take no lock and make no system call
 * (GLOVEPOSE_REALTIME's contract), counted where they would leave the library (glibc only).
 *
 * This program defines malloc, calloc, realloc and the aligned allocators, counting each call and
 * forwarding to glibc's __libc_* functions. The dynamic linker binds the shared library's (and
 * libstdc++'s operator new's) calls to these, so every heap allocation made inside libglovepose_c
 * is seen, whether by operator new, Eigen's aligned_malloc or the C library. It defines the pthread
 * mutex, condition variable and read-write lock calls (std::mutex and std::condition_variable are
 * built on them) and the C library's wrappers of the common system calls the same way, forwarding
 * to the next definition (dlsym RTLD_NEXT). Clocks are not counted: clock_gettime is served by the
 * vDSO, without entering the kernel.
 *
 * Usage: capi_test_allocations MODEL   Last line "N passed, N failed"; exit code 0 when none failed,
 * 77 when GLOVEPOSE_ISA names an instruction set this CPU does not execute (skipped). */
#define _GNU_SOURCE
#include "glovepose_c.h"

#include <dlfcn.h>
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
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

static int passed = 0, failed = 0;
static void check(int condition, const char* what) {
  if (condition) {
    ++passed;
  } else {
    ++failed;
    printf("FAILED: %s\n", what);
  }
}

static void synthetic_cells(double t, double* cells) {
  int c;
  for (c = 0; c < 44; ++c) cells[c] = 20.0 + 5.0 * sin(2.0 * 3.14159265358979 * (0.7 + 0.05 * c) * t + c);
}

int main(int argc, char** argv) {
  glovepose_model* model = NULL;
  glovepose_estimator* estimator = NULL;
  glovepose_estimator_config config;
  glovepose_pose pose;
  glovepose_joint joints[GLOVEPOSE_JOINT_COUNT];
  glovepose_calibration_progress progress;
  glovepose_latest* latest = NULL;
  glovepose_xr_hand hand;
  glovepose_xr_aim_state aim;
  glovepose_predicted_pose ahead;
  uint64_t number = 0;
  int32_t step = 0;
  double sequence_seconds = 0.0;
  double cells[44], frame[180];
  unsigned long before, during, locks_before, locks_during, calls_before, calls_during;
  const char* isa;
  int f, r, solved = 0;
  if (argc != 2) {
    printf("usage: %s MODEL\n", argv[0]);
    return 2;
  }
  isa = glovepose_isa();
  if (isa == NULL) {
    printf("skipped: %s\n", glovepose_last_error());
    return 77;
  }
  printf("networks: %s\n", isa);
  /* Set-up allocates; the counter must see it (else the interposition does not work here). */
  before = allocations;
  if (glovepose_model_load(argv[1], GLOVEPOSE_WEIGHTS_F32, NULL, &model) != GLOVEPOSE_OK) {
    printf("cannot load %s: %s\n", argv[1], glovepose_last_error());
    return 1;
  }
  check(allocations - before > 10, "loading the model is seen allocating (the counter works)");
  glovepose_estimator_config_default(&config);
  config.smoothing = 1;
  config.joint_transforms = 1;
  check(glovepose_estimator_create(model, &config, &estimator) == GLOVEPOSE_OK, "create");
  glovepose_pose_init(&pose);
  glovepose_calibration_progress_init(&progress);
  glovepose_xr_hand_init(&hand);
  glovepose_predicted_pose_init(&ahead);
  glovepose_xr_aim_state_init(&aim);
  /* Calibrate from rows of a synthetic glove (set-up: finish allocates the range). */
  glovepose_calibration_start(estimator);
  for (f = 0; f < 40; ++f) {
    synthetic_cells(f / 60.0, cells);
    for (r = 0; r < 180; ++r) glovepose_estimator_push_row(estimator, r, cells[r % 44] + cells[(r / 15) % 44], f / 60.0 + r / 10800.0);
  }
  check(glovepose_calibration_finish(estimator) == GLOVEPOSE_OK, "finish the calibration");
  check(glovepose_latest_create(&latest) == GLOVEPOSE_OK, "create the latest-hand snapshot");
  /* The lock and system-call counters must see calls too: a mutex, a write. */
  {
    pthread_mutex_t probe = PTHREAD_MUTEX_INITIALIZER;
    locks_before = locks;
    calls_before = system_calls;
    pthread_mutex_lock(&probe);
    pthread_mutex_unlock(&probe);
    fflush(stdout);
    (void)!write(1, "", 0);
    check(locks - locks_before == 1 && system_calls - calls_before >= 1, "a lock and a system call are counted (the counters work)");
  }

  fflush(stdout);
  before = allocations;
  locks_before = locks;
  calls_before = system_calls;
  glovepose_calibration_start(estimator); /* while a calibration collects, and after */
  for (f = 40; f < 100; ++f) { /* 10,800 rows and 780 other per-frame calls */
    if (f == 60) glovepose_calibration_cancel(estimator);
    synthetic_cells(f / 60.0, cells);
    for (r = 0; r < 180; ++r)
      if (glovepose_estimator_push_row(estimator, r, cells[r % 44] + cells[(r / 15) % 44], f / 60.0 + r / 10800.0) == GLOVEPOSE_SOLVED)
        ++solved;
    glovepose_estimator_get_pose(estimator, &pose);
    glovepose_estimator_get_joints(estimator, joints, GLOVEPOSE_JOINT_COUNT);
    glovepose_estimator_get_cells(estimator, cells, 44);
    glovepose_calibration_get_progress(estimator, &progress);
    glovepose_calibration_get_step(estimator, &step, &sequence_seconds);
    glovepose_latest_publish(latest, estimator);
    glovepose_latest_read(latest, &pose, joints, GLOVEPOSE_JOINT_COUNT, &number);
    glovepose_estimator_get_pose_at(estimator, f / 60.0 + 0.02, &ahead);
    glovepose_estimator_get_xr_joints(estimator, f / 60.0 + 0.02, &hand);
    glovepose_estimator_get_xr_joints(estimator, f / 60.0 - 0.01, &hand);
    glovepose_latest_get_xr_joints(latest, estimator, f / 60.0 + 0.02, &hand);
    glovepose_estimator_get_xr_aim(estimator, &aim);
    glovepose_latest_get_xr_aim(latest, &aim, &number);
  }
  for (r = 0; r < 180; ++r) frame[r] = 30.0 + 0.01 * r;
  glovepose_estimator_push_measurements(estimator, frame, 180, 2.0);
  synthetic_cells(2.1, cells);
  glovepose_estimator_push_cells(estimator, cells, 44, 2.1, 0.0);
  /* Rejections and per-frame errors (they write the last-error buffer) allocate nothing either. */
  glovepose_estimator_push_row(estimator, 3, NAN, 3.0);
  glovepose_estimator_push_row(NULL, 3, 1.0, 3.0);
  glovepose_estimator_get_joints(estimator, joints, 3);
  pose.struct_size = 1;
  glovepose_estimator_get_pose(estimator, &pose);
  glovepose_estimator_reset(estimator);
  during = allocations - before;
  locks_during = locks - locks_before;
  calls_during = system_calls - calls_before;
  printf("per-frame calls: %d poses, %lu heap allocations, %lu locks, %lu system calls\n", solved, during, locks_during, calls_during);
  check(solved > 400, "poses were computed (11.25 per 180-row cycle)");
  check(during == 0, "no heap allocation in the per-frame calls");
  check(locks_during == 0, "no lock in the per-frame calls");
  check(calls_during == 0, "no system call in the per-frame calls");

  check(number > 0, "the snapshot was read");
  check(hand.active == 1, "OpenXR joints were located");
  glovepose_latest_free(latest);
  glovepose_estimator_free(estimator);
  glovepose_model_free(model);
  printf("%d passed, %d failed\n", passed, failed);
  return failed == 0 ? 0 : 1;
}
