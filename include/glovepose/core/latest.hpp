/// @file core/latest.hpp
/// @brief The newest value from one writer thread for any number of reader threads: an engine's
/// update and render threads read the hand the glove's thread last estimated.
///
/// Two slots, each a sequence lock over the value copied as atomic 64-bit words, and a count of
/// publishes. The writer never waits and never looks at the readers: it fills the slot the newest
/// value is not in (sequence odd while it writes), then counts the publish. A reader copies the
/// slot of the newest publish between two reads of that slot's sequence and starts over when they
/// differ or the slot holds a later publish than the one counted (the writer came round to that
/// slot again: two publishes in the time of one copy), so it never returns a torn value and the
/// numbers one reader sees never go back, and a writer stopped half-way through a publish
/// (preempted) never holds readers up: they read the other slot. Every access is atomic, so there
/// is no data race for the memory model or ThreadSanitizer.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "../config.hpp"

namespace glovepose::core {

/// @brief One writer's newest T for many readers. T must be trivially copyable.
template <typename T>
class Latest {
  static_assert(std::is_trivially_copyable_v<T>, "Latest<T> copies T as bytes");

 public:
  /// @brief Nothing published yet: read() returns 0.
  Latest() noexcept {
    for (Slot& slot : slots_)
      for (auto& w : slot.words) w.store(0, std::memory_order_relaxed);
  }
  Latest(const Latest&) = delete;
  Latest& operator=(const Latest&) = delete;

  /// @brief Writer (one thread at a time): makes `value` the newest. Wait-free, allocation-free.
  GLOVEPOSE_REALTIME void publish(const T& value) noexcept {
    std::array<std::uint64_t, kWords> buffer{};
    std::memcpy(buffer.data(), &value, sizeof(T));
    const std::uint64_t count = count_.load(std::memory_order_relaxed);  // only this thread writes it
    Slot& slot = slots_[(count + 1) & 1];                                // not the newest value's slot
    const std::uint64_t s = slot.sequence.load(std::memory_order_relaxed);
    slot.sequence.store(s + 1, std::memory_order_relaxed);  // odd: being written
    std::atomic_thread_fence(std::memory_order_release);
    for (std::size_t i = 0; i < kWords; ++i) slot.words[i].store(buffer[i], std::memory_order_relaxed);
    slot.number.store(count + 1, std::memory_order_relaxed);
    slot.sequence.store(s + 2, std::memory_order_release);
    count_.store(count + 1, std::memory_order_release);
  }

  /// @brief Reader (any thread, any number): copies the newest value into `out` and returns its
  /// number (1 for the first publish; 0: none yet, `out` untouched). Never blocks the writer, never
  /// returns a torn value; starts over only if a second publish reaches its slot during its copy.
  GLOVEPOSE_REALTIME std::uint64_t read(T& out) const noexcept {
    std::array<std::uint64_t, kWords> buffer{};
    for (;;) {
      const std::uint64_t count = count_.load(std::memory_order_acquire);
      if (count == 0) return 0;
      const Slot& slot = slots_[count & 1];
      const std::uint64_t before = slot.sequence.load(std::memory_order_acquire);
      if (before & 1) continue;  // the writer came round to this slot again
      for (std::size_t i = 0; i < kWords; ++i) buffer[i] = slot.words[i].load(std::memory_order_relaxed);
      const std::uint64_t number = slot.number.load(std::memory_order_relaxed);
      std::atomic_thread_fence(std::memory_order_acquire);
      if (slot.sequence.load(std::memory_order_relaxed) != before) continue;  // overwritten during the copy
      // The writer came round to this slot between our count and our copy and finished a newer
      // publish whose count it has not stored yet: returning it could be followed by an older
      // number on the next read. Returning only the number counted keeps numbers from going back.
      if (number != count) continue;
      std::memcpy(static_cast<void*>(&out), buffer.data(), sizeof(T));  // T is trivially copyable
      return number;
    }
  }

  /// @brief How many values were published so far (a cheap "is there something new?").
  GLOVEPOSE_REALTIME std::uint64_t published() const noexcept { return count_.load(std::memory_order_acquire); }

 private:
  static constexpr std::size_t kWords = (sizeof(T) + sizeof(std::uint64_t) - 1) / sizeof(std::uint64_t);
  struct alignas(64) Slot {
    std::atomic<std::uint64_t> sequence{0};  // odd while the writer fills the slot
    std::atomic<std::uint64_t> number{0};    // which publish the slot holds (1, 2, ...)
    std::array<std::atomic<std::uint64_t>, kWords> words;
  };
  alignas(64) std::atomic<std::uint64_t> count_{0};  // publishes completed; the newest is in slot count & 1
  std::array<Slot, 2> slots_;
};

}  // namespace glovepose::core
