// One instruction set's networks: compiled once per set of the platform, with that set's flags and
// GLOVEPOSE_VARIANT naming it (CMakeLists.txt, glovepose_compiled). The kernels are instantiated
// for a type of this unit's own (an unnamed namespace), so none of their functions is shared with,
// or replaced at link time by, a copy compiled for another set.
#include <glovepose/model/network_for.hpp>
#include <glovepose/model/network_variants.hpp>

#include <string_view>

#define GLOVEPOSE_JOIN_(a, b) a##b
#define GLOVEPOSE_JOIN(a, b) GLOVEPOSE_JOIN_(a, b)

namespace glovepose::model::detail {
namespace {
struct ThisVariant {};
using Backend = nn::kernels::SimdBackendFor<xsimd::default_arch, ThisVariant>;
}  // namespace

static_assert(std::string_view(nn::isa_word(nn::compiled_isa())) == GLOVEPOSE_VARIANT_WORD,
              "the unit is compiled with the flags of the instruction set it is named for");

/// The factory of this set's networks (declared in network_variants.cpp).
std::shared_ptr<const Network> GLOVEPOSE_JOIN(make_network_, GLOVEPOSE_VARIANT)(const ModelInfo& info, const nn::TensorMap& tensors,
                                                                                 nn::WeightStorage storage) {
  return NetworkFor<Backend>::from_tensors(info, tensors, storage);
}

}  // namespace glovepose::model::detail
