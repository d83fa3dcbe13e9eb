// core::Latest<T> (core/latest.hpp): one writer, many readers, never a torn value; and LatestHand between an
// estimator's thread and two reader threads. Run under ThreadSanitizer by tools/sanitize.sh thread.
#include <glovepose/estimator.hpp>
#include <glovepose/core/latest.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <doctest/doctest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"

using namespace glovepose;

namespace {
// A value whose every word says which publish wrote it: a torn copy mixes two numbers.
struct Stamped {
  std::array<std::uint64_t, 96> words{};  // 768 bytes, about a HandState's size
  bool whole() const noexcept {
    for (std::uint64_t w : words)
      if (w != words[0]) return false;
    return true;
  }
};

// What the reader threads of a test saw: reads, and numbers lower than the one read before.
struct ReadCounts {
  std::atomic<long> reads{0}, backwards{0};
};

// A reader thread's loop: reads `latest` until `done`, counting into `counts`; `check(value, n)`
// inspects every value read and its number.
template <typename T, typename Check>
auto reader_of(const core::Latest<T>& latest, const std::atomic<bool>& done, ReadCounts& counts, Check check) {
  return [&latest, &done, &counts, check] {
    T out;
    std::uint64_t last = 0;
    while (!done.load(std::memory_order_acquire)) {
      const std::uint64_t n = latest.read(out);
      if (n == 0) continue;
      counts.reads.fetch_add(1, std::memory_order_relaxed);
      if (n < last) counts.backwards.fetch_add(1, std::memory_order_relaxed);
      last = n;
      check(out, n);
    }
  };
}
}  // namespace

TEST_CASE("latest: nothing before the first publish, then the newest value and its number") {
  core::Latest<Stamped> latest;
  Stamped out;
  out.words.fill(7);
  CHECK(latest.read(out) == 0);
  CHECK(out.words[0] == 7);  // untouched
  CHECK(latest.published() == 0);
  Stamped v;
  for (std::uint64_t i = 1; i <= 5; ++i) {
    v.words.fill(100 + i);
    latest.publish(v);
  }
  CHECK(latest.read(out) == 5);
  CHECK(out.words[0] == 105);
  CHECK(out.whole());
  CHECK(latest.published() == 5);
  CHECK(test::allocations_during([&] {
          latest.publish(v);
          (void)latest.read(out);
        }) == 0);
}

TEST_CASE("latest: a writer publishing as fast as it can and two readers: never torn, numbers never go back") {
  core::Latest<Stamped> latest;
  constexpr std::uint64_t kPublishes = 200000;
  std::atomic<bool> done{false};
  ReadCounts counts;
  std::atomic<long> torn{0}, mislabelled{0};
  const auto reader = reader_of(latest, done, counts, [&](const Stamped& out, std::uint64_t n) {
    if (!out.whole()) torn.fetch_add(1, std::memory_order_relaxed);
    if (out.words[0] != n) mislabelled.fetch_add(1, std::memory_order_relaxed);
  });
  std::thread a(reader), b(reader);
  Stamped v;
  for (std::uint64_t i = 1; i <= kPublishes; ++i) {
    v.words.fill(i);
    latest.publish(v);
  }
  done.store(true, std::memory_order_release);
  a.join();
  b.join();
  MESSAGE(counts.reads.load() << " reads during " << kPublishes << " publishes");
  CHECK(counts.reads.load() > 0);
  CHECK(torn.load() == 0);
  CHECK(mislabelled.load() == 0);
  CHECK(counts.backwards.load() == 0);
  Stamped last;
  CHECK(latest.read(last) == kPublishes);
  CHECK(last.words[0] == kPublishes);
}

TEST_CASE("latest: an estimator's thread publishes every pose, two readers see whole hand states in order") {
  sim::CorpusConfig config = sim::CorpusConfig::one_session(31, 4.0, 3.0);
  config.recording.raw_rows = true;
  const io::Dataset data = sim::to_dataset(sim::simulate_corpus(config), config);
  EstimatorConfig estimator_config;
  estimator_config.joint_transforms = true;
  GlovePoseEstimator estimator(PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_fcn512.safetensors"),
                               estimator_config);
  LatestHand latest;
  std::vector<std::array<float, 3>> tips(data.frames());  // the pinky tip of pose n, at [n - 1]
  std::atomic<bool> done{false};
  ReadCounts counts;
  std::atomic<long> inconsistent{0};
  const auto reader = reader_of(latest, done, counts, [&](const HandState& state, std::uint64_t n) {
    // Published once per pose: the n-th state carries the n-th pose and that pose's joints
    // (written down by the estimator's thread before it published them).
    if (!state.pose.valid || state.pose.sequence != n || state.joints[20].position != tips[n - 1])
      inconsistent.fetch_add(1, std::memory_order_relaxed);
  });
  std::thread a(reader), b(reader);
  estimator.start_calibration();
  std::size_t published = 0;
  std::vector<double> rows;
  const std::size_t session_start = data.first_session_frame();
  for (std::size_t f = 0; f < data.frames(); ++f) {
    if (f == session_start) estimator.finish_calibration();
    rows.assign(data.raw_rows.begin() + static_cast<std::ptrdiff_t>(f * data.row_count),
                data.raw_rows.begin() + static_cast<std::ptrdiff_t>((f + 1) * data.row_count));
    const Status status = estimator.push_measurements(rows.data(), static_cast<int>(rows.size()), data.timestamps[f]);
    if (status != Status::Solved) continue;
    tips[published++] = estimator.joints()[20].position;
    latest.publish(estimator.state());
  }
  done.store(true, std::memory_order_release);
  a.join();
  b.join();
  CHECK(counts.reads.load() > 0);
  CHECK(counts.backwards.load() == 0);
  CHECK(inconsistent.load() == 0);
  HandState final_state;
  REQUIRE(latest.read(final_state) == published);
  CHECK(final_state.pose.sequence == estimator.pose().sequence);
  CHECK(final_state.pose.timestamp == estimator.pose().timestamp);
  CHECK(final_state.joints[20].position == estimator.joints()[20].position);
  CHECK(test::allocations_during([&] { latest.publish(estimator.state()); }) == 0);
}
