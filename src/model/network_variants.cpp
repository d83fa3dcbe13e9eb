// The compiled library's choice of instruction set (include/glovepose/model/network_variants.hpp).
// Compiled for the platform's baseline: it runs before anything is known about the CPU.
#include <glovepose/model/network_variants.hpp>

#include <string>

namespace glovepose::model {
namespace detail {
// Each built set's factory, defined in its own unit (network_variant.cpp).
using Factory = std::shared_ptr<const Network> (*)(const ModelInfo&, const nn::TensorMap&, nn::WeightStorage);
#define GLOVEPOSE_DECLARE_VARIANT(name) \
  std::shared_ptr<const Network> make_network_##name(const ModelInfo&, const nn::TensorMap&, nn::WeightStorage);
#if defined(GLOVEPOSE_VARIANT_SSE2)
GLOVEPOSE_DECLARE_VARIANT(sse2)
#endif
#if defined(GLOVEPOSE_VARIANT_AVX2)
GLOVEPOSE_DECLARE_VARIANT(avx2)
#endif
#if defined(GLOVEPOSE_VARIANT_AVX512)
GLOVEPOSE_DECLARE_VARIANT(avx512)
#endif
#if defined(GLOVEPOSE_VARIANT_NEON)
GLOVEPOSE_DECLARE_VARIANT(neon)
#endif

struct Variant {
  nn::Isa isa;
  Factory make;
};
// Best last.
constexpr Variant kVariants[] = {
#if defined(GLOVEPOSE_VARIANT_SSE2)
    {nn::Isa::Sse2, make_network_sse2},
#endif
#if defined(GLOVEPOSE_VARIANT_AVX2)
    {nn::Isa::Avx2, make_network_avx2},
#endif
#if defined(GLOVEPOSE_VARIANT_AVX512)
    {nn::Isa::Avx512, make_network_avx512},
#endif
#if defined(GLOVEPOSE_VARIANT_NEON)
    {nn::Isa::Neon, make_network_neon},
#endif
};

const Variant* built_variant(nn::Isa isa) noexcept {
  for (const Variant& v : kVariants)
    if (v.isa == isa) return &v;
  return nullptr;
}

std::string built_words() {
  std::string words;
  for (const Variant& v : kVariants) words += (words.empty() ? "" : ", ") + std::string(nn::isa_word(v.isa));
  return words;
}

nn::Isa choose_isa() {
  if (const std::optional<nn::Isa> asked = nn::isa_from_environment()) {
    if (!built_variant(*asked))
      throw Error(std::string("GLOVEPOSE_ISA is '") + nn::isa_word(*asked) + "', expected one this build holds: " + built_words());
    return *asked;
  }
  for (auto v = std::size(kVariants); v-- > 0;)
    if (nn::cpu_supports(kVariants[v].isa)) return kVariants[v].isa;
  throw Error("this CPU executes none of the instruction sets this build holds: " + built_words());
}
}  // namespace detail

std::vector<nn::Isa> built_isas() {
  std::vector<nn::Isa> isas;
  for (const detail::Variant& v : detail::kVariants) isas.push_back(v.isa);
  return isas;
}

nn::Isa process_isa() {
  static const nn::Isa chosen = detail::choose_isa();  // a throw leaves it unset: the next call asks again
  return chosen;
}

std::shared_ptr<const detail::Network> make_network(nn::Isa isa, const ModelInfo& info, const nn::TensorMap& tensors,
                                                    nn::WeightStorage storage) {
  const detail::Variant* variant = detail::built_variant(isa);
  if (!variant)
    throw Error(std::string("instruction set ") + nn::isa_word(isa) + " asked, expected one this build holds: " + detail::built_words());
  if (!nn::cpu_supports(isa)) throw Error(std::string("instruction set ") + nn::isa_word(isa) + " asked, which this CPU does not execute");
  return variant->make(info, tensors, storage);
}

}  // namespace glovepose::model
