// The compiled library's networks per instruction set (model/network_variants.hpp): which sets the
// CPU executes (against the kernel's own list, /proc/cpuinfo), which one a process runs, and every
// set this CPU executes against the scalar reference kernels on the shipped models.
#include <doctest/doctest.h>

#include <glovepose/model/model_file.hpp>
#include <glovepose/model/pose_network.hpp>
#include <glovepose/nn/kernels/scalar.hpp>
#include <glovepose/pose_model.hpp>
#include <glovepose/pose_model_options.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

using namespace glovepose;

namespace {

const std::string kModels = std::string(GLOVEPOSE_SOURCE_DIR) + "/models/";

model::ModelFile model_file(const std::string& name) {
  return model::load_model_file(kModels + name + ".safetensors", [](model::ModelFile&& file) { return std::move(file); });
}

// Cells in [-1, 1] that vary per cell and frame, as calibrated cells do.
std::vector<double> test_cells(int cells, int frame) {
  std::vector<double> out(static_cast<std::size_t>(cells));
  for (int c = 0; c < cells; ++c) out[static_cast<std::size_t>(c)] = std::sin(0.37 * c + 1.3 * frame) * 0.9;
  return out;
}

}  // namespace

TEST_CASE("network variants: the CPU's instruction sets as the kernel lists them") {
#if defined(__linux__) && (defined(__x86_64__) || defined(__aarch64__))
  std::ifstream cpuinfo("/proc/cpuinfo");
  REQUIRE(cpuinfo);
  std::set<std::string> flags;
  for (std::string line; std::getline(cpuinfo, line);) {
    if (line.rfind("flags", 0) != 0 && line.rfind("Features", 0) != 0) continue;
    std::istringstream words(line.substr(line.find(':') + 1));
    for (std::string word; words >> word;) flags.insert(word);
    break;
  }
  REQUIRE(!flags.empty());
  auto has = [&](std::initializer_list<const char*> names) {
    return std::all_of(names.begin(), names.end(), [&](const char* n) { return flags.count(n) == 1; });
  };
#  if defined(__x86_64__)
  CHECK(nn::cpu_supports(nn::Isa::Sse2) == has({"sse2"}));
  CHECK(nn::cpu_supports(nn::Isa::Avx2) == has({"avx2", "fma", "f16c"}));
  CHECK(nn::cpu_supports(nn::Isa::Avx512) == has({"avx2", "fma", "f16c", "avx512f", "avx512bw", "avx512dq", "avx512vl", "avx512_vbmi2"}));
  CHECK_FALSE(nn::cpu_supports(nn::Isa::Neon));
#  else
  (void)has;  // NEON is ARM64's baseline; under qemu-user /proc/cpuinfo is the host's
  CHECK(nn::cpu_supports(nn::Isa::Neon));
  CHECK_FALSE(nn::cpu_supports(nn::Isa::Avx2));
#  endif
  MESSAGE("this CPU: sse2 " << nn::cpu_supports(nn::Isa::Sse2) << ", avx2 " << nn::cpu_supports(nn::Isa::Avx2) << ", avx512 "
                            << nn::cpu_supports(nn::Isa::Avx512));
#else
  MESSAGE("no /proc/cpuinfo to compare with on this platform");
#endif
}

TEST_CASE("network variants: each instruction set's word names it") {
  for (int i = 0; i < nn::kIsaCount; ++i) CHECK(nn::isa_of_word(nn::isa_word(static_cast<nn::Isa>(i))) == static_cast<nn::Isa>(i));
  CHECK_FALSE(nn::isa_of_word("avx").has_value());
  CHECK_FALSE(nn::isa_of_word("AVX2").has_value());
  CHECK(std::string(nn::isa_word(static_cast<nn::Isa>(nn::kIsaCount))) == "unknown");
}

TEST_CASE("network variants: a process runs GLOVEPOSE_ISA's set, else the best built set the CPU executes") {
  const std::vector<nn::Isa> built = model::built_isas();
  REQUIRE(!built.empty());
#if defined(GLOVEPOSE_COMPILED_LIB) && (defined(__x86_64__) || defined(_M_X64))
  CHECK(built == std::vector<nn::Isa>{nn::Isa::Sse2, nn::Isa::Avx2, nn::Isa::Avx512});
#elif defined(GLOVEPOSE_COMPILED_LIB)
  CHECK(built == std::vector<nn::Isa>{nn::Isa::Neon});
#endif
  const char* asked = std::getenv("GLOVEPOSE_ISA");
  nn::Isa expected = built.front();
  for (nn::Isa isa : built)
    if (nn::cpu_supports(isa)) expected = isa;  // built_isas() is ordered best last
  if (asked != nullptr && *asked != '\0') expected = *nn::isa_of_word(asked);
  CHECK(model::process_isa() == expected);
  const auto model = PoseModel::load(kModels + "glovepose_fcn512.safetensors");
  CHECK(model->network().isa() == expected);
  MESSAGE("this process runs " << nn::isa_word(model::process_isa()));
}

TEST_CASE("network variants: a set the build does not hold or the CPU does not execute is refused") {
  const model::ModelFile file = model_file("glovepose_fcn512");
  for (int i = 0; i < nn::kIsaCount; ++i) {
    const auto isa = static_cast<nn::Isa>(i);
    const std::vector<nn::Isa> built = model::built_isas();
    const bool runs = std::find(built.begin(), built.end(), isa) != built.end() && nn::cpu_supports(isa);
    if (runs) {
      CHECK(model::make_network(isa, file.info, file.tensors, nn::WeightStorage::F32)->isa() == isa);
    } else {
      CHECK_THROWS_AS(model::make_network(isa, file.info, file.tensors, nn::WeightStorage::F32), Error);
    }
  }
}

TEST_CASE("network variants: every set this CPU executes answers as the scalar reference kernels") {
  // The same network with ScalarBackend (one float at a time, no SIMD): each variant's kernels
  // within float rounding of it, in every storage (the same stored weights, widened alike).
  const grid::GridMap map = grid::GloveDescription::glauser2019().map();
  for (const char* name : {"glovepose_fcn512", "glovepose_unet64"}) {
    const model::ModelFile file = model_file(name);
    for (int s = 0; s < nn::kWeightStorageCount; ++s) {
      const auto storage = static_cast<nn::WeightStorage>(s);
      const auto reference = model::detail::NetworkFor<nn::kernels::ScalarBackend>::from_tensors(file.info, file.tensors, storage);
      auto reference_ws = reference->make_workspace(1);
      for (nn::Isa isa : model::built_isas()) {
        if (!nn::cpu_supports(isa)) continue;
        const std::string what = std::string(name) + ", " + nn::storage_name(storage) + ", " + nn::isa_word(isa);
        CAPTURE(what);
        const auto variant = model::make_network(isa, file.info, file.tensors, storage);
        auto ws = variant->make_workspace(1);
        double worst = 0.0;
        for (int frame = 0; frame < 20; ++frame) {
          const std::vector<double> cells = test_cells(file.info.inputs, frame);
          hand::Angles expected{}, got{};
          REQUIRE(reference->normalized_dofs(map, cells.data(), expected, *reference_ws, nullptr) == Status::Ok);
          REQUIRE(variant->normalized_dofs(map, cells.data(), got, *ws, nullptr) == Status::Ok);
          for (std::size_t d = 0; d < hand::kDofCount; ++d) worst = std::max(worst, std::abs(got[d] - expected[d]));
        }
        // Normalised units (2 across a joint's range): float rounding, not a different network.
        // Fixed16 sums the codes and corrects by the sum of the inputs (nn/fixed16.hpp), a
        // cancellation that magnifies the order of summation: 3.2e-4 at most here.
        CHECK(worst < (storage == nn::WeightStorage::Fixed16 ? 1e-3 : 2e-5));
        // A workspace of another set's network is refused, not misread.
        hand::Angles unused{};
        const std::vector<double> cells = test_cells(file.info.inputs, 0);
        CHECK(variant->normalized_dofs(map, cells.data(), unused, *reference_ws, nullptr) == Status::SizeMismatch);
      }
    }
  }
}
