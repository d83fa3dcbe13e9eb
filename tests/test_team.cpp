// core::Team (core/team.hpp) and the U-Net forward shared by a team (UNet::forward with a Team): every
// member runs its share, the outputs equal the one-thread forward's bit for bit, nothing is
// allocated per frame, and an idle team costs no CPU. tests/CMakeLists.txt also runs the
// team tests under ThreadSanitizer (latest_under_tsan's executable).
#include <glovepose/estimator.hpp>
#include <glovepose/core/team.hpp>
#include <glovepose/core/thread_pool.hpp>
#include <glovepose/nn/unet.hpp>
#include <glovepose/sim/corpus_dataset.hpp>

#include <doctest/doctest.h>

#include <time.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "alloc_counter.hpp"
#include "unet_reference.hpp"

using namespace glovepose;
using namespace glovepose::nn;
using core::Team;

namespace {
#if defined(__SANITIZE_THREAD__)
constexpr bool kUnderTsan = true;  // GCC
#elif defined(__has_feature)
#  if __has_feature(thread_sanitizer)
constexpr bool kUnderTsan = true;  // clang
#  else
constexpr bool kUnderTsan = false;
#  endif
#else
constexpr bool kUnderTsan = false;
#endif

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
}  // namespace

TEST_CASE("team: every member runs its share of every job, the caller as member 0, on distinct threads") {
  for (int size : {1, 2, 3}) {
    Team team(size);
    REQUIRE(team.size() == size);
    std::vector<long> counts(static_cast<std::size_t>(size), 0);
    std::vector<std::thread::id> ids(static_cast<std::size_t>(size));
    for (int job = 0; job < 2000; ++job) {
      auto share = [&](int member) noexcept {
        ++counts[static_cast<std::size_t>(member)];  // one writer per slot; run() returns after all
        ids[static_cast<std::size_t>(member)] = std::this_thread::get_id();
      };
      team.run(share);
      if (job == 1000) std::this_thread::sleep_for(std::chrono::milliseconds(5));  // the workers park, then wake
    }
    for (long c : counts) CHECK(c == 2000);
    CHECK(ids[0] == std::this_thread::get_id());
    for (int a = 0; a < size; ++a)
      for (int b = a + 1; b < size; ++b) CHECK(ids[static_cast<std::size_t>(a)] != ids[static_cast<std::size_t>(b)]);
  }
  CHECK_THROWS_AS(Team(0), Error);
}

TEST_CASE("thread pool: shares cover every index once, a member's exception reaches the caller after all have ended") {
  for (int threads : {1, 2, 3}) {
    CAPTURE(threads);
    core::ThreadPool pool(threads);
    CHECK(pool.size() == threads);
    for (long n : {0L, 1L, 2L, 7L, 1000L}) {
      std::vector<int> hits(static_cast<std::size_t>(n), 0);
      std::vector<int> owner(static_cast<std::size_t>(n), -1);
      pool.for_shares(n, [&](core::Range r, int member) {
        for (long i = r.begin; i < r.end; ++i) ++hits[static_cast<std::size_t>(i)], owner[static_cast<std::size_t>(i)] = member;
      });
      for (long i = 0; i < n; ++i) {
        CHECK(hits[static_cast<std::size_t>(i)] == 1);
        // contiguous shares in member order, sizes differing by at most one (share())
        const core::Range expected = core::share(n, owner[static_cast<std::size_t>(i)], threads);
        CHECK((i >= expected.begin && i < expected.end));
      }
    }
    std::atomic<int> finished{0};
    const auto failing = [&](int member) {
      if (member == threads - 1) throw Error("member " + std::to_string(member) + " failed");
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
      ++finished;
    };
    const std::string message = "member " + std::to_string(threads - 1) + " failed";
    CHECK_THROWS_WITH_AS(pool.run(failing), doctest::Contains(message.c_str()), Error);
    CHECK(finished == threads - 1);  // the others ran to their end before run() rethrew
    std::atomic<int> ran{0};
    pool.run([&](int) { ++ran; });  // usable after a failure
    CHECK(ran == threads);
  }
  CHECK_THROWS_WITH_AS(core::ThreadPool(0), doctest::Contains("ThreadPool: 0 threads, expected 1..1024"), Error);
}

TEST_CASE("unet: a team's forward equals the one-thread forward bit for bit, every storage, and allocates nothing") {
  // Width 8: no layer wider than a column panel (the rows are shared); 32 and 64: column panels
  // too; 100: panels of unequal widths (224 and 416 columns with AVX-512: the last panel narrower).
  // Under ThreadSanitizer (-O1, instrumented) width 32 only.
  const std::vector<int> widths = kUnderTsan ? std::vector<int>{32} : std::vector<int>{8, 32, 64, 100};
  for (int width : widths) {
    const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width), 700 + static_cast<unsigned>(width));
    for (WeightStorage storage : {WeightStorage::F32, WeightStorage::F16, WeightStorage::BF16, WeightStorage::Fixed16}) {
      const auto net = UNet<>::from_tensors(tensors, width, 1e-5, storage);
      for (int members : {2, 3}) {
        Team team(members);
        for (int frames : {1, 4, 40}) {  // sparse single frames and small batches; dense large ones
          INFO("width " << width << ", " << std::string(storage_name(storage)) << ", " << members << " members, " << frames << " frames");
          auto alone_ws = net.make_workspace(frames);
          auto team_ws = net.make_workspace(frames, members);
          std::mt19937 rng(static_cast<unsigned>(frames + members));
          std::uniform_real_distribution<float> u(-1.0f, 1.0f);
          std::vector<float> in(static_cast<std::size_t>(frames) * kUNetInputs), alone(static_cast<std::size_t>(frames) * kUNetOutputs),
              shared(alone.size());
          int differing = 0;
          for (int trial = 0; trial < (kUnderTsan ? 2 : 5); ++trial) {  // every barrier still crossed many times
            for (float& v : in) v = u(rng);
            REQUIRE(net.forward(in.data(), alone.data(), frames, alone_ws) == Status::Ok);
            std::size_t allocations = 0;
            Status status = Status::Ok;
            allocations = test::allocations_during([&] { status = net.forward(in.data(), shared.data(), frames, team_ws, team); });
            REQUIRE(status == Status::Ok);
            CHECK(allocations == 0);
            differing += std::memcmp(alone.data(), shared.data(), alone.size() * sizeof(float)) != 0;
          }
          CHECK(differing == 0);
        }
        // A workspace made for a smaller team is refused.
        auto small_ws = net.make_workspace(1, members - 1);
        std::array<float, kUNetInputs> in{};
        std::array<float, kUNetOutputs> out{};
        CHECK(net.forward(in.data(), out.data(), 1, small_ws, team) == Status::SizeMismatch);
      }
    }
  }
}

TEST_CASE("team: an idle team of two uses under 1% of a core") {
  const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(64), 5);
  const auto net = UNet<>::from_tensors(tensors, 64);
  Team team(2);
  auto ws = net.make_workspace(1, 2);
  std::array<float, kUNetInputs> in{};
  std::array<float, kUNetOutputs> out{};
  for (int f = 0; f < 100; ++f) REQUIRE(net.forward(in.data(), out.data(), 1, ws, team) == Status::Ok);
  std::this_thread::sleep_for(std::chrono::milliseconds(50));  // past the spin: the worker parks
  const double cpu_before = process_cpu_seconds();
  const auto wall_before = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  const double cpu = process_cpu_seconds() - cpu_before;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_before).count();
  MESSAGE("idle team: " << 1e3 * cpu << " ms of CPU in " << wall << " s");
  if (!kUnderTsan) CHECK(cpu < 0.01 * wall);  // ThreadSanitizer's own background thread wakes now and then
  // And it still works after parking.
  CHECK(net.forward(in.data(), out.data(), 1, ws, team) == Status::Ok);
}

TEST_CASE("estimator: network_threads 2 gives the one-thread poses of the shipped U-Net, without allocating per row") {
  // Under ThreadSanitizer a quarter of the stream (102 s of the TSan suite's 168 s with all of it):
  // still hundreds of team forwards, each crossing every barrier of the runner.
  sim::CorpusConfig config = sim::CorpusConfig::one_session(41, kUnderTsan ? 0.5 : 2.0, 2.0);
  config.recording.raw_rows = true;
  const io::Dataset data = sim::to_dataset(sim::simulate_corpus(config), config);
  const auto model = PoseModel::load(std::string(GLOVEPOSE_SOURCE_DIR) + "/models/glovepose_unet64.safetensors");
  EstimatorConfig one, two;
  two.network_threads = 2;
  GlovePoseEstimator alone(model, one), shared(model, two);
  alone.start_calibration();
  shared.start_calibration();
  const std::size_t rows = data.row_count;
  long poses = 0, differing = 0;
  std::size_t allocations = 0;
  const std::size_t session_start = data.first_session_frame();
  for (std::size_t f = 0; f < data.frames(); ++f) {
    if (f == session_start) {
      alone.finish_calibration();
      shared.finish_calibration();
    }
    for (std::size_t r = 0; r < rows; ++r) {
      const double t = data.row_time(f, r);
      const double value = data.raw_rows[f * rows + r];
      const Status a = alone.push_row(static_cast<int>(r), value, t);
      Status b = Status::Ok;
      allocations += test::allocations_during([&] { b = shared.push_row(static_cast<int>(r), value, t); });
      REQUIRE(a == b);
      if (a != Status::Solved) continue;
      ++poses;
      differing += alone.pose().angles != shared.pose().angles;
    }
  }
  CHECK(poses > (kUnderTsan ? 250 : 1000));
  CHECK(differing == 0);
  CHECK(allocations == 0);
  EstimatorConfig bad;
  bad.network_threads = 0;
  CHECK_THROWS_WITH_AS(GlovePoseEstimator(model, bad), doctest::Contains("network_threads 0"), Error);
}
