/* What the per-frame path must not do, counted since the program started (realtime_counters.c:
 * glibc's allocators, pthread locks and system-call wrappers interposed). Link realtime_counters.c
 * into the program; C and C++. */
#ifndef GLOVEPOSE_TESTS_REALTIME_COUNTERS_H
#define GLOVEPOSE_TESTS_REALTIME_COUNTERS_H

#ifdef __cplusplus
extern "C" {
#endif

unsigned long realtime_allocations(void);  /* malloc, calloc, realloc and the aligned allocators */
unsigned long realtime_locks(void);        /* pthread mutex, condition variable and rwlock calls */
unsigned long realtime_system_calls(void); /* read, write, close, sleeps, yield, mmap, munmap, poll, syscall */

#ifdef __cplusplus
}
#endif

#endif
