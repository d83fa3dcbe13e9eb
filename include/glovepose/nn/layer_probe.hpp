/// @file layer_probe.hpp
/// @brief A compile-time hook on the U-Net runner's layer parts, for timing experiments
/// (tools/experiments/team_layers.cpp) without copying or patching the library.
///
/// The runner (unet_run.hpp) calls `GLOVEPOSE_LAYER_PROBE::mark(event, member)` at each event
/// below. By default that is NoLayerProbe, whose empty inline function the compiler removes, so the
/// per-frame path is the same code as without the hook. A program that wants the events includes
/// this header, defines GLOVEPOSE_LAYER_PROBE to its own type with the same static function, then
/// includes the network (unet_run.hpp picks NoLayerProbe when the macro is not defined). Every translation unit of one program must see the same probe (the runner is a template:
/// two probes in one program would be two definitions of one function).
#pragma once

namespace glovepose::nn {

/// @brief Where the runner is. `member` is the team member for ShareBegin/ShareEnd, else 0.
enum class LayerEvent {
  Forward,          ///< A forward begins (before its first layer).
  LayerBegin,       ///< A layer begins.
  CompactionBegin,  ///< A layer's sparse sources start being compacted (small batches).
  CompactionEnd,    ///< ... and are compacted.
  HandOver,         ///< The layer's products are handed to a team.
  ShareBegin,       ///< A team member starts its share of the products (on its own thread).
  ShareEnd,         ///< ... and ends it.
  ProductsEnd,      ///< The layer's products are done (on the calling thread).
  FinishEnd,        ///< Fixed16 only: scale, offset and bias applied after the products.
  ActivationBegin,  ///< The activation starts.
  ActivationEnd,    ///< The activation is done: the layer is done.
};

/// @brief The default probe: nothing.
struct NoLayerProbe {
  static void mark(LayerEvent, int /*member*/ = 0) noexcept {}
};

}  // namespace glovepose::nn
