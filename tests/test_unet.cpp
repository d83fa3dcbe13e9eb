#include <glovepose/nn/unet_diagnostics.hpp>
#include <glovepose/grid/grid_map.hpp>
#include <glovepose/hand/dofs.hpp>
#include <glovepose/model/unet_model.hpp>
#include <glovepose/model/pose_network.hpp>

#include <doctest/doctest.h>

#include <cstdlib>
#include <fstream>
#include <random>

#include "alloc_counter.hpp"
#include "unet_reference.hpp"

using namespace glovepose;
using namespace glovepose::nn;

namespace {
std::vector<float> random_inputs(int frames, unsigned seed, float range = 1.0f) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-range, range);  // calibrated stretch maps lie in [-1, 1]
  std::vector<float> x(static_cast<std::size_t>(frames * kUNetInputs));
  for (float& v : x) v = u(rng);
  return x;
}

template <typename Backend>
double max_difference_to_reference(const TensorMap& tensors, int width, int frames, unsigned seed) {
  const auto net = UNet<Backend>::from_tensors(tensors, width);
  if (frames == 1) {  // up to kSparseMaxFrames frames: the sparse products; more: the dense ones
    auto ws = net.make_workspace(1);
    const std::vector<float> x = random_inputs(4, seed);
    double worst = 0.0;
    for (int f = 0; f < 4; ++f) {
      std::array<float, kUNetOutputs> y{};
      std::array<float, kUNetInputs> in{};
      std::copy_n(x.begin() + f * kUNetInputs, kUNetInputs, in.begin());
      REQUIRE(net.forward(in, y, ws) == Status::Ok);
      const std::vector<double> expected = test::unet_reference(tensors, in.data());
      for (int i = 0; i < kUNetOutputs; ++i)
        worst = std::max(worst, std::abs(expected[static_cast<std::size_t>(i)] - y[static_cast<std::size_t>(i)]));
    }
    return worst;
  }
  auto ws = net.make_workspace(frames);
  const std::vector<float> x = random_inputs(frames, seed);
  std::vector<float> y(static_cast<std::size_t>(frames * kUNetOutputs));
  REQUIRE(net.forward(x.data(), y.data(), frames, ws) == Status::Ok);
  double worst = 0.0;
  for (int f = 0; f < frames; ++f) {
    const std::vector<double> expected = test::unet_reference(tensors, x.data() + f * kUNetInputs);
    for (int i = 0; i < kUNetOutputs; ++i)
      worst = std::max(worst, std::abs(expected[static_cast<std::size_t>(i)] - y[static_cast<std::size_t>(f * kUNetOutputs + i)]));
  }
  return worst;
}

std::size_t paper_parameter_count(std::size_t w) {
  // Conv weights (Table 6 with concatenating skips) + conv biases + BN scale and shift.
  const std::size_t weights = 2 * w * 25 + w * 2 * w * 9 + 2 * w * 4 * w * 9 + 4 * w * 8 * w * 16 + 8 * w * 4 * w * 16 + 8 * w * 2 * w * 9 +
                              4 * w * w * 9 + 2 * w * 25;
  return weights + (22 * w + 1) + 2 * (2 * w + 4 * w + 8 * w + 4 * w + 2 * w + w);
}
}  // namespace

TEST_CASE("unet: presets have the paper's sizes, the fixed 5x5 grid lets most 4x4 taps go unread") {
  for (const UNetPreset& p : kUNetPresets) {
    const auto tensors = UNet<>::expected_tensors(p.width);
    std::size_t count = 0;
    for (const auto& [name, shape] : tensors) {
      if (name.find("running_") != std::string::npos) continue;
      std::size_t n = 1;
      for (auto d : shape) n *= static_cast<std::size_t>(d);
      count += n;
    }
    MESSAGE(std::string(p.name) << " (w = " << p.width << "): " << count << " parameters");
    CHECK(count == paper_parameter_count(static_cast<std::size_t>(p.width)));
  }
  CHECK(paper_parameter_count(48) == doctest::Approx(3.0e6).epsilon(0.02));
  CHECK(paper_parameter_count(64) == doctest::Approx(5.3e6).epsilon(0.01));
  CHECK(paper_parameter_count(100) == doctest::Approx(13.0e6).epsilon(0.01));
  CHECK(paper_parameter_count(196) == doctest::Approx(50.0e6).epsilon(0.01));
  const auto net = UNet<>::from_tensors(test::random_tensors(UNet<>::expected_tensors(64), 1), 64);
  CHECK(net.parameter_count() == paper_parameter_count(64));
  MESSAGE("w = 64: " << net.stored_weight_count() << " weights can meet a 5x5 input; " << net.weight_bytes() << " bytes packed (F32)");
  CHECK(net.stored_weight_count() == doctest::Approx(2.2e6).epsilon(0.03));
  // Multiply-adds per frame, counted by hand from the tap plans (docs/performance.md):
  // enc1 361*2w, enc2 49*w*2w, enc3 16*2w*4w, enc4 4*4w*8w, dec1 4*8w*4w, dec2 16*8w*2w, dec3 49*4w*w, out 361*2w.
  const std::size_t w = 64;
  const std::size_t macs = 361 * 2 * w + 49 * w * 2 * w + 16 * 2 * w * 4 * w + 4 * 4 * w * 8 * w + 4 * 8 * w * 4 * w + 16 * 8 * w * 2 * w +
                           49 * 4 * w * w + 361 * 2 * w;
  MESSAGE("w = 64: " << net.mac_count() << " multiply-adds per frame");
  CHECK(net.mac_count() == macs);
}

TEST_CASE("unet: the SIMD and scalar backends equal an independent reference forward (random weights, BN included)") {
  // Widths 1..3 and 4 exercise the im2col path in enc4/enc3/enc2 and output channels narrower than
  // a vector; 13 padded channels; 64 the paper's network.
  for (int width : {1, 2, 3, 4, 13, 64}) {
    CAPTURE(width);
    const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width), 100 + static_cast<unsigned>(width));
    for (const int frames : {kSparseMaxFrames + 1, 6, 1}) {  // dense products; sparse ones over several frames, over one
      CAPTURE(frames);
      const double simd = max_difference_to_reference<kernels::SimdBackend>(tensors, width, frames, 7);
      const double scalar = max_difference_to_reference<kernels::ScalarBackend>(tensors, width, frames, 7);
      MESSAGE("w = " << width << ", " << frames << " frame(s): max |simd - reference| = " << simd
                     << ", max |scalar - reference| = " << scalar);
      CHECK(simd <= 1e-5);
      CHECK(scalar <= 1e-5);
    }
  }
}

TEST_CASE("unet: extra input planes (a glove's inputs off the maps) are read as the independent reference reads them, in every storage") {
  // Widths 4 and 13 (padded channels); 1 and 3 extra planes: enc1 then joins 75 or 125 taps x
  // channels, past im2col's 64, so it runs as per-tap products (F32 even under Fixed16).
  for (int width : {4, 13}) {
    for (int extra : {1, 3}) {
      CAPTURE(width);
      CAPTURE(extra);
      const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width, extra), 500 + static_cast<unsigned>(width + extra));
      const auto simd = UNet<>::from_tensors(tensors, width);
      const auto scalar = UNet<kernels::ScalarBackend>::from_tensors(tensors, width);
      REQUIRE(simd.extra_inputs() == extra);
      REQUIRE(simd.input_values() == (2 + extra) * 25);
      std::mt19937 rng(8);
      std::uniform_real_distribution<float> u(-1.0f, 1.0f);
      const int frames = kSparseMaxFrames + 2;
      std::vector<float> x(static_cast<std::size_t>(frames * simd.input_values()));
      for (float& v : x) v = u(rng);
      for (int f = 0; f < frames; ++f)  // as GridMap::to_input_planes writes them: each extra plane one value
        for (int e = 0; e < extra; ++e)
          std::fill_n(x.begin() + f * simd.input_values() + (2 + e) * 25 + 1, 24,
                      x[static_cast<std::size_t>(f * simd.input_values() + (2 + e) * 25)]);
      std::vector<float> dense(static_cast<std::size_t>(frames * kUNetOutputs)), single = dense, small = dense, scalar_out = dense;
      auto dense_ws = simd.make_workspace(frames), one = simd.make_workspace(1), small_ws = simd.make_workspace(6);
      auto scalar_ws = scalar.make_workspace(frames);
      REQUIRE(simd.forward(x.data(), dense.data(), frames, dense_ws) == Status::Ok);
      REQUIRE(scalar.forward(x.data(), scalar_out.data(), frames, scalar_ws) == Status::Ok);
      REQUIRE(simd.forward(x.data(), small.data(), 6, small_ws) == Status::Ok);
      for (int f = 0; f < frames; ++f)
        REQUIRE(simd.forward(x.data() + f * simd.input_values(), single.data() + f * kUNetOutputs, 1, one) == Status::Ok);
      double worst = 0.0;
      for (int f = 0; f < frames; ++f) {
        const std::vector<double> expected = test::unet_reference(tensors, x.data() + f * simd.input_values());
        for (int i = 0; i < kUNetOutputs; ++i) {
          const std::size_t at = static_cast<std::size_t>(f * kUNetOutputs + i);
          worst = std::max({worst, std::abs(expected[static_cast<std::size_t>(i)] - dense[at]),
                            std::abs(expected[static_cast<std::size_t>(i)] - single[at]),
                            std::abs(expected[static_cast<std::size_t>(i)] - scalar_out[at])});
          if (f < 6) worst = std::max(worst, std::abs(expected[static_cast<std::size_t>(i)] - small[at]));
        }
      }
      MESSAGE("w = " << width << ", " << extra << " extra plane(s): max |ours - reference| = " << worst);
      CHECK(worst <= 1e-5);
      for (const WeightStorage storage : {WeightStorage::F16, WeightStorage::BF16, WeightStorage::Fixed16}) {
        const auto narrow = UNet<>::from_tensors(tensors, width, 1e-5, storage);
        auto ws = narrow.make_workspace(frames);
        std::vector<float> y(dense.size());
        REQUIRE(narrow.forward(x.data(), y.data(), frames, ws) == Status::Ok);
        double gap = 0.0;
        for (std::size_t i = 0; i < y.size(); ++i) gap = std::max(gap, static_cast<double>(std::abs(y[i] - dense[i])));
        CAPTURE(static_cast<int>(storage));
        CHECK(gap < 1e-2);  // the 16-bit storages' rounding (their own tests bound it per storage)
      }
      // The array form is the maps-only network's; a workspace of the maps-only network does not fit.
      std::array<float, kUNetInputs> maps{};
      std::array<float, kUNetOutputs> out{};
      CHECK(simd.forward(maps, out, one) == Status::SizeMismatch);
      const auto plain = UNet<>::from_tensors(test::random_tensors(UNet<>::expected_tensors(width), 3), width);
      auto plain_ws = plain.make_workspace(1);
      CHECK(simd.forward(x.data(), out.data(), 1, plain_ws) == Status::SizeMismatch);
      CHECK(test::allocations_during([&] { (void)simd.forward(x.data(), out.data(), 1, one); }) == 0);
    }
  }
}

TEST_CASE("unet: equals PyTorch with two extra input planes (committed fixture, width 4)") {
  const std::string dir = std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/";
  const WeightFile file = WeightFile::read(dir + "unet_w4_e2.safetensors");
  const auto net = UNet<>::from_tensors(file.tensors, 4);
  REQUIRE(net.extra_inputs() == 2);
  const WeightFile io = WeightFile::read(dir + "unet_w4_e2_io.safetensors");
  const Tensor& x = io.tensors.at("input");
  const Tensor& y = io.tensors.at("output");
  REQUIRE(x.shape == std::vector<std::int64_t>{x.shape[0], 4, 5, 5});
  const int frames = static_cast<int>(x.shape[0]);
  auto ws = net.make_workspace(frames);
  std::vector<float> out(static_cast<std::size_t>(frames * kUNetOutputs));
  REQUIRE(net.forward(x.values.data(), out.data(), frames, ws) == Status::Ok);
  double worst = 0.0;
  for (std::size_t i = 0; i < out.size(); ++i) worst = std::max(worst, static_cast<double>(std::abs(out[i] - y.values[i])));
  MESSAGE("fixture: " << frames << " frames, max |C++ - PyTorch| = " << worst);
  CHECK(worst <= 1e-5);
  // enc1.weight reading 2 + 300 planes is refused, naming the tensor.
  TensorMap wide = file.tensors;
  wide["enc1.weight"] = Tensor{{4, 302, 5, 5}, std::vector<float>(4 * 302 * 25, 0.0f)};
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(wide, 4),
                       doctest::Contains("'enc1.weight' reads 302 input planes, expected 2 stretch maps and at most 256 extra"), Error);
}

TEST_CASE("unet: a batch gives the same outputs as frames one at a time, forward_batch on threads too") {
  const int width = 16, frames = 37;
  const auto net = UNet<>::from_tensors(test::random_tensors(UNet<>::expected_tensors(width), 3), width);
  const std::vector<float> x = random_inputs(frames, 11);
  std::vector<float> batched(static_cast<std::size_t>(frames * kUNetOutputs)), single = batched, threaded = batched;
  auto ws = net.make_workspace(frames), one = net.make_workspace(1);
  REQUIRE(net.forward(x.data(), batched.data(), frames, ws) == Status::Ok);
  for (int f = 0; f < frames; ++f) REQUIRE(net.forward(x.data() + f * kUNetInputs, single.data() + f * kUNetOutputs, 1, one) == Status::Ok);
  net.forward_batch(x.data(), threaded.data(), frames, 2, 8);
  for (std::size_t i = 0; i < batched.size(); ++i) {
    CHECK(batched[i] == doctest::Approx(single[i]).epsilon(1e-6).scale(1.0));
    CHECK(threaded[i] == doctest::Approx(single[i]).epsilon(1e-6).scale(1.0));
  }
}

// What a single-frame forward must read of the weights, from the convolutions' definitions and the
// independent reference forward's activations: per row-product layer and kernel tap, the input
// positions the tap joins to an output, and per source the channels nonzero at one of them.
std::size_t expected_weight_bytes_read(const TensorMap& tensors, const float* input, int width, std::size_t product_weight_size) {
  const std::vector<test::Grid> act = test::unet_reference_activations(tensors, input);  // e1 e2 e3 e4 d1 d2 d3 y
  struct Layer {
    int in, out, k, s, p;
    bool transposed;
    std::vector<int> sources;  // indices into act
    int out_channels;
  };
  const int w = width;
  const Layer products[] = {{5, 3, 3, 2, 1, false, {0}, 2 * w}, {3, 2, 3, 2, 1, false, {1}, 4 * w},   {2, 1, 4, 2, 1, false, {2}, 8 * w},
                            {1, 2, 4, 2, 1, true, {3}, 4 * w},  {2, 3, 3, 2, 1, true, {4, 2}, 2 * w}, {3, 5, 3, 2, 1, true, {5, 1}, w}};
  const auto nonzero_rows = [&](const test::Grid& g, const std::vector<std::pair<int, int>>& positions) {
    std::size_t rows = 0;
    for (int c = 0; c < g.channels; ++c) {
      bool any = false;
      for (const auto& [y, x] : positions) any = any || g.at(c, y, x) != 0.0;
      rows += any;
    }
    return rows;
  };
  std::size_t bytes = 25 * 2 * static_cast<std::size_t>(w) * 4;  // enc1 (F32): every tap of a 5x5 kernel, padding 2, meets input
  for (const Layer& l : products)
    for (int ky = 0; ky < l.k; ++ky)
      for (int kx = 0; kx < l.k; ++kx) {
        const auto joins = [&](int i, int kk) {  // does input index i meet some output along this tap?
          for (int o = 0; o < l.out; ++o)
            if ((l.transposed ? i * l.s - l.p + kk == o : o * l.s - l.p + kk == i)) return true;
          return false;
        };
        std::vector<std::pair<int, int>> positions;
        for (int y = 0; y < l.in; ++y)
          for (int x = 0; x < l.in; ++x)
            if (joins(y, ky) && joins(x, kx)) positions.emplace_back(y, x);
        for (int src : l.sources)
          bytes +=
              nonzero_rows(act[static_cast<std::size_t>(src)], positions) * static_cast<std::size_t>(l.out_channels) * product_weight_size;
      }
  std::vector<std::pair<int, int>> everywhere;  // out (F32): a row per nonzero source channel, the 25 taps as its columns
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x) everywhere.emplace_back(y, x);
  const std::size_t tap_columns = (25 + kernels::SimdBackend::lanes - 1) / kernels::SimdBackend::lanes * kernels::SimdBackend::lanes;
  for (int src : {6, 0}) bytes += nonzero_rows(act[static_cast<std::size_t>(src)], everywhere) * tap_columns * 4;
  return bytes;
}

TEST_CASE("unet: weight_bytes_read counts the weight rows a single frame meets, as the convolutions and the reference forward say") {
  const int width = 32;  // every hidden layer's channels are whole pairs of SIMD vectors: no padding but the last layer's
  TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width), 23);
  const std::vector<float> x = random_inputs(1, 8);
  for (const WeightStorage storage : {WeightStorage::F32, WeightStorage::Fixed16}) {
    CAPTURE(storage_name(storage));
    const auto net = UNet<>::from_tensors(tensors, width, 1e-5, storage);
    auto ws = net.make_workspace(1);
    std::vector<float> y(kUNetOutputs);
    REQUIRE(net.forward(x.data(), y.data(), 1, ws) == Status::Ok);
    const std::size_t read = nn::weight_bytes_read(net, ws);
    const std::size_t expected = expected_weight_bytes_read(tensors, x.data(), width, storage == WeightStorage::F32 ? 4 : 2);
    MESSAGE(std::string(storage_name(storage)) << ": " << read << " of " << net.weight_bytes() << " bytes read, expected " << expected);
    // float against double: a pre-activation within rounding of zero may fall either side (one row of the widest layer).
    CHECK(std::abs(static_cast<double>(read) - static_cast<double>(expected)) <= 8.0 * width * 4);
    CHECK(read < net.weight_bytes());
    const auto other = UNet<>::from_tensors(test::random_tensors(UNet<>::expected_tensors(4), 9), 4);
    CHECK_THROWS_WITH_AS((void)nn::weight_bytes_read(other, ws), doctest::Contains("expected width 4"), Error);
  }
  // A first layer that only ever outputs -1 before its ReLU: no row fed by e1 is read.
  std::fill(tensors.at("enc1.weight").values.begin(), tensors.at("enc1.weight").values.end(), 0.0f);
  std::fill(tensors.at("enc1.bias").values.begin(), tensors.at("enc1.bias").values.end(), -1.0f);
  const auto net = UNet<>::from_tensors(tensors, width);
  auto ws = net.make_workspace(1);
  std::vector<float> y(kUNetOutputs);
  REQUIRE(net.forward(x.data(), y.data(), 1, ws) == Status::Ok);
  CHECK(std::abs(static_cast<double>(nn::weight_bytes_read(net, ws)) -
                 static_cast<double>(expected_weight_bytes_read(tensors, x.data(), width, 4))) <= 8.0 * width * 4);
}

TEST_CASE("unet: zero_fractions counts the zeros each ReLU leaves as the independent reference forward does") {
  const int width = 16, frames = 3;
  TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width), 21);
  const std::vector<float> x = random_inputs(frames, 5);
  const auto fractions_of = [&](const TensorMap& t) {
    const auto net = UNet<>::from_tensors(t, width);
    auto ws = net.make_workspace(frames);
    std::vector<float> y(static_cast<std::size_t>(frames * kUNetOutputs));
    REQUIRE(net.forward(x.data(), y.data(), frames, ws) == Status::Ok);
    std::array<double, 7> reference{};
    std::array<double, 7> size{};
    for (int f = 0; f < frames; ++f) {
      const std::vector<test::Grid> acts = test::unet_reference_activations(t, x.data() + f * kUNetInputs);
      for (std::size_t l = 0; l < reference.size(); ++l) {
        reference[l] += static_cast<double>(std::count(acts[l].v.begin(), acts[l].v.end(), 0.0));
        size[l] += static_cast<double>(acts[l].v.size());
      }
    }
    const auto fractions = nn::zero_fractions(net, ws, frames);
    for (std::size_t l = 0; l < reference.size(); ++l) {
      CAPTURE(l);
      // float against double: a pre-activation within rounding of zero may fall either side.
      CHECK(std::abs(fractions[l] - reference[l] / size[l]) <= 2.0 / size[l]);
    }
    CHECK_THROWS_WITH_AS((void)nn::zero_fractions(net, ws, frames + 1), doctest::Contains("4 frames, expected 1..3"), Error);
    const auto other = UNet<>::from_tensors(test::random_tensors(UNet<>::expected_tensors(4), 9), 4);
    CHECK_THROWS_WITH_AS((void)nn::zero_fractions(other, ws, 1), doctest::Contains("expected width 4"), Error);
    return fractions;
  };
  const auto random = fractions_of(tensors);
  MESSAGE("random w = 16 network, zero fractions e1..d3: " << random[0] << " " << random[1] << " " << random[2] << " " << random[3] << " "
                                                           << random[4] << " " << random[5] << " " << random[6]);
  for (double f : random) CHECK((f > 0.2 && f < 0.8));  // about half, as docs/performance.md says
  // A first layer that only ever outputs -1 before its ReLU: all of e1 is zero.
  std::fill(tensors.at("enc1.weight").values.begin(), tensors.at("enc1.weight").values.end(), 0.0f);
  std::fill(tensors.at("enc1.bias").values.begin(), tensors.at("enc1.bias").values.end(), -1.0f);
  CHECK(fractions_of(tensors)[0] == 1.0);
}

TEST_CASE("unet: bad input gets a status and the single-frame forward allocates nothing") {
  const auto net = UNet<>::from_tensors(test::random_tensors(UNet<>::expected_tensors(64), 9), 64);
  auto ws = net.make_workspace();
  std::array<float, kUNetInputs> in{};
  std::array<float, kUNetOutputs> out{};
  out.fill(5.0f);
  in[17] = std::numeric_limits<float>::quiet_NaN();
  CHECK(net.forward(in, out, ws) == Status::NonFinite);
  CHECK(out[0] == 5.0f);
  in[17] = 0.5f;
  CHECK(net.forward(in.data(), out.data(), 2, ws) == Status::SizeMismatch);  // capacity 1
  const auto other = UNet<>::from_tensors(test::random_tensors(UNet<>::expected_tensors(4), 9), 4);
  auto small = other.make_workspace();
  CHECK(net.forward(in, out, small) == Status::SizeMismatch);  // a workspace of another network
  CHECK_THROWS_WITH_AS((void)net.make_workspace(0), doctest::Contains("capacity 0, expected 1.."), Error);
  CHECK(test::allocations_during([&] { (void)net.forward(in, out, ws); }) == 0);
  for (float v : out) CHECK(std::abs(v) < 1.0f);
}

TEST_CASE(
    "unet: BF16 weights: SIMD (pair layout) and scalar backends agree, sparse (single frames, small batches) and dense (large batches)") {
  for (int width : {1, 3, 16, 24, 64}) {  // 1, 3, 24: channels padded to whole pairs of vectors
    CAPTURE(width);
    const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width), 300 + static_cast<unsigned>(width));
    const auto simd = UNet<>::from_tensors(tensors, width, 1e-5, WeightStorage::BF16);
    const auto scalar = UNet<kernels::ScalarBackend>::from_tensors(tensors, width, 1e-5, WeightStorage::BF16);
    const int frames = kSparseMaxFrames + 3, small = 9;  // dense products; sparse ones over `small` frames
    const std::vector<float> x = random_inputs(frames, 5);
    std::vector<float> batched(static_cast<std::size_t>(frames * kUNetOutputs)), single = batched, reference = batched,
                                                                                 small_batch = batched;
    auto ws = simd.make_workspace(frames), one = simd.make_workspace(1), small_ws = simd.make_workspace(small);
    auto scalar_ws = scalar.make_workspace(frames);
    REQUIRE(simd.forward(x.data(), batched.data(), frames, ws) == Status::Ok);
    REQUIRE(simd.forward(x.data(), small_batch.data(), small, small_ws) == Status::Ok);
    REQUIRE(scalar.forward(x.data(), reference.data(), frames, scalar_ws) == Status::Ok);
    for (int f = 0; f < frames; ++f)
      REQUIRE(simd.forward(x.data() + f * kUNetInputs, single.data() + f * kUNetOutputs, 1, one) == Status::Ok);
    for (std::size_t i = 0; i < batched.size(); ++i) {
      CHECK(batched[i] == doctest::Approx(reference[i]).epsilon(1e-5).scale(1.0));
      CHECK(single[i] == doctest::Approx(reference[i]).epsilon(1e-5).scale(1.0));
      if (i < static_cast<std::size_t>(small * kUNetOutputs))
        CHECK(small_batch[i] == doctest::Approx(reference[i]).epsilon(1e-5).scale(1.0));
    }
  }
}

TEST_CASE(
    "unet: Fixed16 weights: SIMD (pair layout) and scalar backends, sparse (single frames, small batches) and dense (large batches), near "
    "F32") {
  for (int width : {1, 3, 16, 24, 64}) {  // 1, 3, 24: channels padded to whole pairs of vectors
    CAPTURE(width);
    const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width), 400 + static_cast<unsigned>(width));
    const auto exact = UNet<>::from_tensors(tensors, width, 1e-5, WeightStorage::F32);
    const auto simd = UNet<>::from_tensors(tensors, width, 1e-5, WeightStorage::Fixed16);
    const auto scalar = UNet<kernels::ScalarBackend>::from_tensors(tensors, width, 1e-5, WeightStorage::Fixed16);
    const auto f16 = UNet<>::from_tensors(tensors, width, 1e-5, WeightStorage::F16);
    const int frames = kSparseMaxFrames + 3, small = 9;  // dense products; sparse ones over `small` frames
    const std::vector<float> x = random_inputs(frames, 6);
    std::vector<float> reference(static_cast<std::size_t>(frames * kUNetOutputs)),
        batched = reference, single = reference, scalar_out = reference, f16_out = reference,
        small_batch(static_cast<std::size_t>(small * kUNetOutputs));
    auto ws = simd.make_workspace(frames), one = simd.make_workspace(1), exact_ws = exact.make_workspace(frames);
    auto small_ws = simd.make_workspace(small);
    REQUIRE(simd.forward(x.data(), small_batch.data(), small, small_ws) == Status::Ok);
    auto scalar_ws = scalar.make_workspace(frames);
    auto f16_ws = f16.make_workspace(frames);
    REQUIRE(exact.forward(x.data(), reference.data(), frames, exact_ws) == Status::Ok);
    REQUIRE(simd.forward(x.data(), batched.data(), frames, ws) == Status::Ok);
    REQUIRE(scalar.forward(x.data(), scalar_out.data(), frames, scalar_ws) == Status::Ok);
    REQUIRE(f16.forward(x.data(), f16_out.data(), frames, f16_ws) == Status::Ok);
    for (int f = 0; f < frames; ++f)
      REQUIRE(simd.forward(x.data() + f * kUNetInputs, single.data() + f * kUNetOutputs, 1, one) == Status::Ok);
    // The two backends pair columns differently (their own lane counts), so their codes round
    // differently: each is compared with F32, within the codes' rounding (2^-16 of a channel's
    // largest weight) carried through the network; and F16 (11 significant bits) errs more.
    double worst[4] = {0.0, 0.0, 0.0, 0.0}, worst_f16 = 0.0;
    for (std::size_t i = 0; i < reference.size(); ++i) {
      worst[0] = std::max(worst[0], static_cast<double>(std::abs(batched[i] - reference[i])));
      worst[1] = std::max(worst[1], static_cast<double>(std::abs(single[i] - reference[i])));
      worst[2] = std::max(worst[2], static_cast<double>(std::abs(scalar_out[i] - reference[i])));
      if (i < small_batch.size()) worst[3] = std::max(worst[3], static_cast<double>(std::abs(small_batch[i] - reference[i])));
      worst_f16 = std::max(worst_f16, static_cast<double>(std::abs(f16_out[i] - reference[i])));
    }
    MESSAGE("width " << width << ": Fixed16 vs F32 " << worst[0] << " (batch), " << worst[1] << " (single), " << worst[2] << " (scalar), "
                     << worst[3] << " (small batch); F16 vs F32 " << worst_f16);
    for (double w : worst) {
      CHECK(w < 2e-4);
      CHECK(w < worst_f16);
    }
  }
}

TEST_CASE("unet: 16-bit weights (F16, BF16, Fixed16) stay within 0.1 degree of the exact F32 path on calibrated inputs") {
  const int width = 64, frames = 256;
  const TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(width), 21);
  const auto exact = UNet<>::from_tensors(tensors, width, 1e-5, WeightStorage::F32);
  auto ws = exact.make_workspace(frames);
  const std::vector<float> x = random_inputs(frames, 4);
  std::vector<float> a(static_cast<std::size_t>(frames * kUNetOutputs));
  REQUIRE(exact.forward(x.data(), a.data(), frames, ws) == Status::Ok);
  for (const WeightStorage storage : {WeightStorage::F16, WeightStorage::BF16, WeightStorage::Fixed16}) {
    const auto half = UNet<>::from_tensors(tensors, width, 1e-5, storage);
    if (storage == WeightStorage::Fixed16)  // the first and last layers (F32) and one scale per channel: under 1% more
      CHECK(half.weight_bytes() * 2 < exact.weight_bytes() * 101 / 100);
    else
      CHECK(half.weight_bytes() * 2 == exact.weight_bytes());
    auto ws16 = half.make_workspace(frames);
    std::vector<float> b = a;
    REQUIRE(half.forward(x.data(), b.data(), frames, ws16) == Status::Ok);
    // Pose-map slot -> DoF, and the angle a unit of output is worth: (max - min) / 2 (dofs.hpp).
    const auto slots = grid::GridMap::paper_pose_slots();
    double worst_degrees = 0.0;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      const double radians_per_unit = 0.5 * (hand::kDofs[d].max - hand::kDofs[d].min);
      for (int f = 0; f < frames; ++f) {
        const std::size_t i = static_cast<std::size_t>(f * kUNetOutputs + slots[d].flat());
        worst_degrees = std::max(worst_degrees, std::abs(a[i] - b[i]) * radians_per_unit * core::kDegreesPerRadian);
      }
    }
    const std::string name = storage_name(storage);
    MESSAGE(name << " weights vs F32: largest angle difference " << worst_degrees << " degrees over " << frames << " frames");
    CHECK(worst_degrees < 0.1);
  }
}

TEST_CASE("unet: folded weights the storage cannot hold are refused, naming the layer") {
  TensorMap tensors = test::random_tensors(UNet<>::expected_tensors(16), 12);
  tensors["bn3.weight"].values.assign(64, 1e4f);
  tensors["bn3.running_var"].values.assign(64, 0.0f);  // valid, but scales enc3 by 1e4 / sqrt(1e-5)
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(tensors, 16, 1e-5, WeightStorage::F16),
                       doctest::Contains("layer enc3 with bn3 folded in has a weight of"), Error);
  CHECK_NOTHROW(UNet<>::from_tensors(tensors, 16, 1e-5, WeightStorage::F32));
  CHECK_NOTHROW(UNet<>::from_tensors(tensors, 16, 1e-5, WeightStorage::BF16));  // bfloat16 has float's range
  tensors["bn3.weight"].values.assign(64, 1.0f);
  tensors["bn3.running_var"].values.assign(64, 1.0f);
  tensors["enc3.weight"].values[5] = 3.4e38f;  // folded 3.39998e38: bfloat16 rounds it up past its largest (3.3895e38)
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(tensors, 16, 1e-5, WeightStorage::BF16), doctest::Contains("too large for BF16 storage"),
                       Error);
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(tensors, 0), doctest::Contains("width 0, expected 1..4096"), Error);
}

TEST_CASE("unet: equals PyTorch on the committed fixtures (width 4)") {
  const std::string dir = std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/";
  const auto loaded = model::UNetModel<>::load(dir + "unet_w4.safetensors");
  const WeightFile io = WeightFile::read(dir + "unet_w4_io.safetensors");
  const Tensor& x = io.tensors.at("input");
  const Tensor& y = io.tensors.at("output");
  const int frames = static_cast<int>(x.shape[0]);
  REQUIRE(frames > 0);
  auto ws = loaded.unet.make_workspace(frames);
  std::vector<float> out(static_cast<std::size_t>(frames * kUNetOutputs));
  REQUIRE(loaded.unet.forward(x.values.data(), out.data(), frames, ws) == Status::Ok);
  double worst = 0.0;
  for (std::size_t i = 0; i < out.size(); ++i) worst = std::max(worst, static_cast<double>(std::abs(out[i] - y.values[i])));
  MESSAGE("fixture: " << frames << " frames, max |C++ - PyTorch| = " << worst);
  CHECK(worst <= 1e-5);
}

TEST_CASE("unet: equals PyTorch for every preset (fixtures regenerated with PyTorch when it is installed)") {
  const std::string python = "/usr/bin/python3";
  if (std::system((python + " -c 'import torch' > /dev/null 2>&1").c_str()) != 0) {
    const char* required = std::getenv("GLOVEPOSE_REQUIRE_TORCH");
    if (required && std::string(required) == "1") FAIL("PyTorch is not installed and GLOVEPOSE_REQUIRE_TORCH=1");
    MESSAGE("NOT CHECKED: PyTorch (Debian python3-torch) is not installed, so the presets were not compared with it");
    return;
  }
  for (const UNetPreset& p : kUNetPresets) {
    INFO("preset " << p.name);
    const std::string base = std::string(GLOVEPOSE_TEST_TMP_DIR) + "/torch_" + p.name;
    const std::string cmd = python + " " + GLOVEPOSE_SOURCE_DIR + "/tools/python/make_fixtures.py --width " + std::to_string(p.width) +
                            " --seed 7 --batch 8 --out-model " + base + ".safetensors --out-io " + base + "_io.safetensors";
    REQUIRE(std::system(cmd.c_str()) == 0);
    const auto loaded = model::UNetModel<>::load(base + ".safetensors");
    const WeightFile io = WeightFile::read(base + "_io.safetensors");
    const int frames = static_cast<int>(io.tensors.at("input").shape[0]);
    auto ws = loaded.unet.make_workspace(frames);
    std::vector<float> out(static_cast<std::size_t>(frames * kUNetOutputs));
    REQUIRE(loaded.unet.forward(io.tensors.at("input").values.data(), out.data(), frames, ws) == Status::Ok);
    double worst = 0.0;
    for (std::size_t i = 0; i < out.size(); ++i)
      worst = std::max(worst, static_cast<double>(std::abs(out[i] - io.tensors.at("output").values[i])));
    MESSAGE(std::string(p.name) << " (w = " << p.width << "): max |C++ - PyTorch| = " << worst);
    CHECK(worst <= 1e-5);
    std::remove((base + ".safetensors").c_str());
    std::remove((base + "_io.safetensors").c_str());
  }
}

namespace {
// Multiply-adds of one convolution on square grids, counting the (output, tap, input) triples whose
// input lies inside the grid, as unet_reference.hpp's conv loops them; and the taps that meet any.
struct ConvCount {
  std::size_t macs = 0, weights = 0;
};
ConvCount count_conv(const TensorMap& t, const std::string& name, int in_size, int out_size, int k, int s, int p, bool transposed) {
  const std::vector<std::int64_t>& shape = t.at(name + ".weight").shape;  // [out, in, k, k]; transposed [in, out, k, k]
  const auto channels = static_cast<std::size_t>(shape[0] * shape[1]);
  std::size_t pairs = 0, taps = 0;  // along one axis
  for (int tap = 0; tap < k; ++tap) {
    std::size_t meets = 0;
    for (int a = 0; a < (transposed ? in_size : out_size); ++a) {
      const int b = a * s - p + tap;
      meets += b >= 0 && b < (transposed ? out_size : in_size);
    }
    pairs += meets;
    taps += meets > 0;
  }
  return {pairs * pairs * channels, taps * taps * channels};
}
}  // namespace

TEST_CASE("pose network: multiply-adds and kept weights for a U-Net and an FCN, counted from the layer shapes") {
  // U-Net w = 8 reading one extra input plane: the paper's layers (Table 6), as unet_reference.hpp runs them.
  const TensorMap unet_tensors = test::random_tensors(UNet<>::expected_tensors(8, 1), 21);
  ConvCount unet{};
  for (const ConvCount& c : {count_conv(unet_tensors, "enc1", 5, 5, 5, 1, 2, false), count_conv(unet_tensors, "enc2", 5, 3, 3, 2, 1, false),
                             count_conv(unet_tensors, "enc3", 3, 2, 3, 2, 1, false), count_conv(unet_tensors, "enc4", 2, 1, 4, 2, 1, false),
                             count_conv(unet_tensors, "dec1", 1, 2, 4, 2, 1, true), count_conv(unet_tensors, "dec2", 2, 3, 3, 2, 1, true),
                             count_conv(unet_tensors, "dec3", 3, 5, 3, 2, 1, true), count_conv(unet_tensors, "out", 5, 5, 5, 1, 2, false)}) {
    unet.macs += c.macs;
    unet.weights += c.weights;
  }
  const glovepose::model::PoseNetwork unet_net(UNet<>::from_tensors(unet_tensors, 8));
  CHECK(unet_net.mac_count() == unet.macs);
  CHECK(unet_net.stored_weight_count() == unet.weights);

  // FCN, 44 cells, hidden 32: each layer multiplies its [out, in] weight matrix once per frame.
  TensorMap fcn_tensors;
  std::mt19937 rng(22);
  std::uniform_real_distribution<float> u(-0.1f, 0.1f);
  for (const auto& [name, shape] : fcn_tensor_shapes(44, 32)) {
    Tensor& t = fcn_tensors[name] = Tensor{shape, {}};
    t.values.resize(static_cast<std::size_t>(t.element_count()));
    for (float& v : t.values) v = u(rng);
  }
  std::size_t fcn_macs = 0;
  for (int l = 1; l <= kFcnLayers; ++l) {
    const std::vector<std::int64_t>& shape = fcn_tensors.at("fc" + std::to_string(l) + ".weight").shape;
    fcn_macs += static_cast<std::size_t>(shape[0] * shape[1]);
  }
  const glovepose::model::PoseNetwork fcn_net(Fcn<>::from_tensors(fcn_tensors, 44, 32));
  CHECK(fcn_net.mac_count() == fcn_macs);
  CHECK(fcn_net.stored_weight_count() == fcn_macs);
  CHECK(fcn_macs == 44 * 32 + 3 * 32 * 32 + 32 * 16 + 16 * 25);  // tests/test_cli.cpp's figure for this shape
}
