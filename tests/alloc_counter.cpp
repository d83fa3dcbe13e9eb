#include "alloc_counter.hpp"

#include <atomic>
#include <cstdlib>
#include <new>
#ifdef _WIN32
#  include <malloc.h>  // _aligned_malloc, _aligned_free
#endif

namespace {
std::atomic<std::size_t> g_allocations{0};

void* counted_alloc(std::size_t size, std::size_t alignment) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (size == 0) size = 1;
  void* p = nullptr;
#ifdef _WIN32
  const bool plain = alignment == 0;  // only the unaligned forms: their delete is free()
#else
  const bool plain = alignment <= alignof(std::max_align_t);
#endif
  if (plain) {
    p = std::malloc(size);
  } else {
    const std::size_t rounded = (size + alignment - 1) / alignment * alignment;
#ifdef _WIN32
    p = _aligned_malloc(rounded, alignment);  // Windows' C library has no aligned_alloc
#else
    p = std::aligned_alloc(alignment, rounded);
#endif
  }
  if (!p) throw std::bad_alloc();
  return p;
}
}  // namespace

std::size_t glovepose::test::allocation_count() noexcept { return g_allocations.load(std::memory_order_relaxed); }

// For a program that finds the counter at run time (dlsym), e.g. `glovepose soak` with this file
// built as libglovepose_alloc_counter.so and preloaded.
extern "C" std::size_t glovepose_allocation_count() noexcept { return glovepose::test::allocation_count(); }

void* operator new(std::size_t size) { return counted_alloc(size, 0); }
void* operator new[](std::size_t size) { return counted_alloc(size, 0); }
void* operator new(std::size_t size, std::align_val_t a) { return counted_alloc(size, static_cast<std::size_t>(a)); }
void* operator new[](std::size_t size, std::align_val_t a) { return counted_alloc(size, static_cast<std::size_t>(a)); }
namespace {
// Memory of the over-aligned operator new: on Windows _aligned_malloc's, freed by _aligned_free.
void aligned_free(void* p) noexcept {
#ifdef _WIN32
  _aligned_free(p);
#else
  std::free(p);
#endif
}
}  // namespace

void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { aligned_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { aligned_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { aligned_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { aligned_free(p); }
