/// @file pose_network.hpp
/// @brief The network a PoseModel runs, whichever architecture its file holds: calibrated cell
/// values -> normalised DoF values (-1 and +1 at the joint limits). The U-Net reads the cells as
/// the glove's two stretch maps (and one constant plane per extra input) and answers a pose map,
/// which the glove's grid map turns back into DoFs; the FCN reads the cells and answers the DoFs.
/// Both keep their weights in the storage chosen at load and are immutable once loaded; each stream
/// owns a Workspace. Header-only use runs the kernels the including code is compiled for; with the
/// compiled library (GLOVEPOSE_COMPILED_LIB) a network is built with the best instruction set this
/// CPU executes, or GLOVEPOSE_ISA's (network_variants.hpp).
#pragma once

#include <memory>
#include <utility>
#include <vector>

#include "../config.hpp"
#include "../core/team.hpp"
#include "../grid/grid_map.hpp"
#include "../hand/dofs.hpp"
#include "../nn/isa.hpp"
#include "../status.hpp"
#include "model_info.hpp"
#include "network_for.hpp"
#include "network_variants.hpp"

namespace glovepose::model {

/// @brief A U-Net or an FCN behind one per-frame call.
class PoseNetwork {
 public:
  /// @brief The U-Net with the header-only kernels.
  using UNet = nn::UNet<>;
  /// @brief The FCN with the header-only kernels.
  using Fcn = nn::Fcn<>;

  /// @brief Wraps a loaded U-Net (header-only kernels).
  PoseNetwork(UNet unet)  // NOLINT: implicit, a U-Net is a pose network
      : net_(std::make_shared<detail::NetworkFor<nn::kernels::SimdBackend>>(std::move(unet))) {}
  /// @brief Wraps a loaded FCN (header-only kernels).
  PoseNetwork(Fcn fcn)  // NOLINT: implicit, an FCN is a pose network
      : net_(std::make_shared<detail::NetworkFor<nn::kernels::SimdBackend>>(std::move(fcn))) {}

  /// @brief The network a model file's metadata names, built from its tensors with weights kept as
  /// `storage`, in this process's instruction set (process_isa(): with the compiled library the
  /// best this CPU executes or GLOVEPOSE_ISA's; header-only, the including code's). Throws glovepose::Error for an architecture the real-time path
  /// does not run (a linear map: train::load_model evaluates it) or tensors that do not make the network.
  static PoseNetwork from_tensors(const ModelInfo& info, const nn::TensorMap& tensors, nn::WeightStorage storage) {
    return PoseNetwork(make_network(process_isa(), info, tensors, storage));
  }

  /// @brief The instruction set its kernels run.
  nn::Isa isa() const noexcept { return net_->isa(); }
  /// @brief Architecture::UNet or Architecture::Fcn.
  Architecture architecture() const noexcept { return net_->architecture(); }
  /// @brief The U-Net with the header-only kernels, or null (an FCN, or a network of the compiled library).
  const UNet* unet() const noexcept { return net_->header_only_unet(); }
  /// @brief The FCN with the header-only kernels, or null (a U-Net, or a network of the compiled library).
  const Fcn* fcn() const noexcept { return net_->header_only_fcn(); }
  /// @brief Weight storage chosen at load.
  nn::WeightStorage storage() const noexcept { return net_->storage(); }
  /// @brief Trainable parameters of the network.
  std::size_t parameter_count() const noexcept { return net_->parameter_count(); }
  /// @brief Multiply-adds per frame that meet real input (the U-Net's padding skipped): the
  /// arithmetic floor of a forward.
  std::size_t mac_count() const noexcept { return net_->mac_count(); }
  /// @brief Weights kept after load (batch norm folded, the U-Net's taps that only meet padding
  /// dropped; biases not counted).
  std::size_t stored_weight_count() const noexcept { return net_->stored_weight_count(); }
  /// @brief Bytes of packed weights a dense forward streams.
  std::size_t weight_bytes() const noexcept { return net_->weight_bytes(); }
  /// @brief Cells a frame must hold: the FCN's inputs; 0 for a U-Net (any glove whose map fills its grid).
  int required_cells() const noexcept { return net_->required_cells(); }
  /// @brief The U-Net's extra input planes (enc1 reads 2 + this many); 0 for an FCN.
  int extra_inputs() const noexcept { return net_->extra_inputs(); }
  /// @brief The U-Net's width w, or the FCN's hidden width.
  int width() const noexcept { return net_->width(); }
  /// @brief Values of one frame's input: the U-Net's planes ((2 + extra_inputs()) x 5 x 5), or the FCN's cells.
  int input_values() const noexcept { return net_->input_values(); }

  /// @brief One stream's scratch for single frames.
  class Workspace {
   private:
    friend class PoseNetwork;
    std::unique_ptr<detail::NetworkWorkspace> net;
  };

  /// @brief A workspace for single frames, for a U-Net forward by a team of up to `team_size`
  /// members (set-up: allocates).
  Workspace make_workspace(int team_size = 1) const {
    Workspace ws;
    ws.net = net_->make_workspace(team_size);
    return ws;
  }

  /// @brief One frame: `cells` calibrated cell values (`map`'s glove) -> `normalized` DoF values.
  /// Returns Status::NonFinite (normalized untouched) for a NaN or infinite cell or result,
  /// Status::SizeMismatch for a workspace of another kind of network (or none) or a U-Net whose
  /// extra input planes are not `map`'s extra inputs; never allocates.
  /// A U-Net's layers are shared by `team`'s members when one is given (UNet::forward with a
  /// Team: the same results); an FCN runs on the calling thread.
  GLOVEPOSE_REALTIME Status normalized_dofs(const grid::GridMap& map, const double* cells, hand::Angles& normalized, Workspace& ws,
                                            core::Team* team = nullptr) const noexcept {
    if (!ws.net) return Status::SizeMismatch;
    return net_->normalized_dofs(map, cells, normalized, *ws.net, team);
  }

  /// @brief The network alone, one frame: the U-Net's input planes -> its 5 x 5 pose map, or the
  /// FCN's cells -> its normalised DoFs (input_values() in). Status::SizeMismatch for a workspace
  /// of another kind of network; never allocates.
  GLOVEPOSE_REALTIME Status forward(const float* input, float* output, Workspace& ws) const noexcept {
    if (!ws.net) return Status::SizeMismatch;
    return net_->forward(input, output, *ws.net);
  }

  /// @brief The batch path for evaluation: `frames` rows of `cell_count` calibrated cell values ->
  /// one row of normalised DoF values each, on `threads` threads. Set-up code: allocates; throws
  /// glovepose::Error naming the first frame with a non-finite value.
  std::vector<hand::Angles> normalized_dofs_batch(const grid::GridMap& map, const float* cells, int cell_count, long frames,
                                                  int threads = 1) const {
    return net_->normalized_dofs_batch(map, cells, cell_count, frames, threads);
  }

 private:
  explicit PoseNetwork(std::shared_ptr<const detail::Network> net) : net_(std::move(net)) {}
  std::shared_ptr<const detail::Network> net_;  // immutable: copies share it
};

}  // namespace glovepose::model
