/// @file network_variants.hpp
/// @brief Which instruction set a process's networks run, and a network built in a given one.
///
/// Header-only use has one variant: the kernels the including code is compiled for. The compiled
/// library (GLOVEPOSE_COMPILED_LIB, CMake target glovepose::compiled) holds one per instruction set
/// of its platform (x86-64: sse2, avx2, avx512; ARM64: neon), each built in a unit of its own with
/// that set's compiler flags (src/model/network_variant.cpp), and chooses one per process: the one
/// GLOVEPOSE_ISA names, else the best this CPU executes.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "../config.hpp"
#include "../nn/isa.hpp"
#include "../nn/weights.hpp"
#include "model_info.hpp"
#include "network_for.hpp"

namespace glovepose::model {

#if defined(GLOVEPOSE_COMPILED_LIB)

/// @brief The instruction sets this build holds networks for, best last.
std::vector<nn::Isa> built_isas();

/// @brief The set this process's networks run, chosen at its first call: GLOVEPOSE_ISA's, else the
/// best built set this CPU executes. Throws glovepose::Error when GLOVEPOSE_ISA names no set, one
/// this CPU does not execute or one this build does not hold.
nn::Isa process_isa();

/// @brief The network of a model file (PoseNetwork::from_tensors) with `isa`'s kernels. Throws
/// glovepose::Error for a set this build does not hold or this CPU does not execute.
std::shared_ptr<const detail::Network> make_network(nn::Isa isa, const ModelInfo& info, const nn::TensorMap& tensors,
                                                    nn::WeightStorage storage);

#else

/// @brief The instruction sets this build holds networks for: the including code's.
inline std::vector<nn::Isa> built_isas() { return {nn::compiled_isa()}; }

/// @brief The set this process's networks run: the including code's (GLOVEPOSE_ISA is read only by
/// the compiled library).
inline nn::Isa process_isa() { return nn::compiled_isa(); }

/// @brief The network of a model file with the header-only kernels; `isa` must be theirs.
inline std::shared_ptr<const detail::Network> make_network(nn::Isa isa, const ModelInfo& info, const nn::TensorMap& tensors,
                                                           nn::WeightStorage storage) {
  if (isa != nn::compiled_isa())
    throw Error(std::string("instruction set ") + nn::isa_word(isa) + " asked, expected " + nn::isa_word(nn::compiled_isa()) +
                " (header-only use runs the kernels it is compiled for; the compiled library holds the others)");
  return detail::NetworkFor<nn::kernels::SimdBackend>::from_tensors(info, tensors, storage);
}

#endif

}  // namespace glovepose::model
