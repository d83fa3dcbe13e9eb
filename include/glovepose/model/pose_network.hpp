/// @file pose_network.hpp
/// @brief The network a PoseModel runs, whichever architecture its file holds: calibrated cell
/// values -> normalised DoF values (-1 and +1 at the joint limits). The U-Net reads the cells as
/// the glove's two stretch maps (and one constant plane per extra input) and answers a pose map,
/// which the glove's grid map turns back into DoFs; the FCN reads the cells and answers the DoFs.
/// Both keep their weights in the storage chosen at load and are immutable once loaded; each stream
/// owns a Workspace.
#pragma once

#include <array>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "../config.hpp"
#include "../core/team.hpp"
#include "../grid/grid_map.hpp"
#include "../hand/dofs.hpp"
#include "../nn/fcn.hpp"
#include "../nn/unet.hpp"
#include "../status.hpp"
#include "model_info.hpp"

namespace glovepose::model {

/// @brief A U-Net or an FCN behind one per-frame call.
class PoseNetwork {
 public:
  /// @brief The U-Net (SIMD kernels).
  using UNet = nn::UNet<>;
  /// @brief The FCN (SIMD kernels).
  using Fcn = nn::Fcn<>;

  /// @brief Wraps a loaded U-Net.
  PoseNetwork(UNet unet) : net_(std::move(unet)) {}  // NOLINT: implicit, a U-Net is a pose network
  /// @brief Wraps a loaded FCN.
  PoseNetwork(Fcn fcn) : net_(std::move(fcn)) {}  // NOLINT: implicit, an FCN is a pose network

  /// @brief The network a model file's metadata names, built from its tensors with weights kept as
  /// `storage`. Throws glovepose::Error for an architecture the real-time path does not run (a
  /// linear map: train::load_model evaluates it) or tensors that do not make the network.
  static PoseNetwork from_tensors(const ModelInfo& info, const nn::TensorMap& tensors, nn::WeightStorage storage) {
    if (info.architecture == Architecture::UNet) return UNet::from_tensors(tensors, info.width, info.bn_eps, storage);
    if (info.architecture == Architecture::Fcn) return Fcn::from_tensors(tensors, info.inputs, info.width, storage);
    throw Error("architecture '" + info.architecture_name() +
                "' has no real-time network, expected 'unet' or 'fcn' (train::load_model evaluates every architecture)");
  }

  /// @brief Architecture::UNet or Architecture::Fcn.
  Architecture architecture() const noexcept { return unet() ? Architecture::UNet : Architecture::Fcn; }
  /// @brief The U-Net, or null for an FCN.
  const UNet* unet() const noexcept { return std::get_if<UNet>(&net_); }
  /// @brief The FCN, or null for a U-Net.
  const Fcn* fcn() const noexcept { return std::get_if<Fcn>(&net_); }
  /// @brief Weight storage chosen at load.
  nn::WeightStorage storage() const noexcept {
    return std::visit([](const auto& net) { return net.storage(); }, net_);
  }
  /// @brief Trainable parameters of the network.
  std::size_t parameter_count() const noexcept {
    return std::visit([](const auto& net) { return net.parameter_count(); }, net_);
  }
  /// @brief Multiply-adds per frame that meet real input (the U-Net's padding skipped): the
  /// arithmetic floor of a forward.
  std::size_t mac_count() const noexcept {
    return std::visit([](const auto& net) { return net.mac_count(); }, net_);
  }
  /// @brief Weights kept after load (batch norm folded, the U-Net's taps that only meet padding
  /// dropped; biases not counted).
  std::size_t stored_weight_count() const noexcept {
    return std::visit([](const auto& net) { return net.stored_weight_count(); }, net_);
  }
  /// @brief Bytes of packed weights a dense forward streams.
  std::size_t weight_bytes() const noexcept {
    return std::visit([](const auto& net) { return net.weight_bytes(); }, net_);
  }
  /// @brief Cells a frame must hold: the FCN's inputs; 0 for a U-Net (any glove whose map fills its grid).
  int required_cells() const noexcept { return fcn() ? fcn()->inputs() : 0; }

  /// @brief One stream's scratch for single frames.
  class Workspace {
   private:
    friend class PoseNetwork;
    std::variant<typename UNet::Workspace, typename Fcn::Workspace> net;
    std::vector<float> planes;  // U-Net input: the stretch maps and the extra inputs' planes
    std::array<float, grid::kMapSlots> pose_map{};
    std::vector<float> cells;  // FCN input
    std::array<float, nn::kFcnOutputs> dofs{};
  };

  /// @brief A workspace for single frames, for a U-Net forward by a team of up to `team_size`
  /// members (set-up: allocates).
  Workspace make_workspace(int team_size = 1) const {
    Workspace ws;
    if (const UNet* u = unet()) {
      ws.net = u->make_workspace(1, team_size);
      ws.planes.resize(static_cast<std::size_t>(u->input_values()));
    } else {
      ws.net = fcn()->make_workspace(1);
      ws.cells.resize(static_cast<std::size_t>(fcn()->inputs()));
    }
    return ws;
  }

  /// @brief One frame: `cells` calibrated cell values (`map`'s glove) -> `normalized` DoF values.
  /// Returns Status::NonFinite (normalized untouched) for a NaN or infinite cell or result,
  /// Status::SizeMismatch for a workspace of another network or a U-Net whose extra input planes
  /// are not `map`'s extra inputs; never allocates.
  /// A U-Net's layers are shared by `team`'s members when one is given (UNet::forward with a
  /// Team: the same results); an FCN runs on the calling thread.
  GLOVEPOSE_REALTIME Status normalized_dofs(const grid::GridMap& map, const double* cells, hand::Angles& normalized, Workspace& ws,
                                            core::Team* team = nullptr) const noexcept {
    if (const UNet* u = unet()) {
      auto* w = std::get_if<typename UNet::Workspace>(&ws.net);
      if (!w || map.input_plane_count() * grid::kMapSlots != u->input_values() ||
          ws.planes.size() != static_cast<std::size_t>(u->input_values()))
        return Status::SizeMismatch;
      if (map.to_input_planes(cells, ws.planes.data()) != Status::Ok) return Status::NonFinite;
      const Status status = team != nullptr ? u->forward(ws.planes.data(), ws.pose_map.data(), 1, *w, *team)
                                            : u->forward(ws.planes.data(), ws.pose_map.data(), 1, *w);
      if (status != Status::Ok) return status;
      map.from_pose_map(ws.pose_map, normalized);
      return Status::Ok;
    }
    auto* w = std::get_if<typename Fcn::Workspace>(&ws.net);
    if (!w || ws.cells.size() != static_cast<std::size_t>(fcn()->inputs())) return Status::SizeMismatch;
    for (std::size_t c = 0; c < ws.cells.size(); ++c) ws.cells[c] = static_cast<float>(cells[c]);
    const Status status = fcn()->forward(ws.cells.data(), ws.dofs.data(), 1, *w);
    if (status != Status::Ok) return status;
    for (std::size_t d = 0; d < hand::kDofCount; ++d) normalized[d] = ws.dofs[d];
    return Status::Ok;
  }

  /// @brief The batch path for evaluation: `frames` rows of `cell_count` calibrated cell values ->
  /// one row of normalised DoF values each, on `threads` threads. Set-up code: allocates; throws
  /// glovepose::Error naming the first frame with a non-finite value.
  std::vector<hand::Angles> normalized_dofs_batch(const grid::GridMap& map, const float* cells, int cell_count, long frames,
                                                  int threads = 1) const {
    std::vector<hand::Angles> out(static_cast<std::size_t>(frames));
    if (frames <= 0) return out;
    if (const UNet* u = unet()) {
      const long values = u->input_values();
      if (cell_count != map.cell_count() || map.input_plane_count() * grid::kMapSlots != values)
        throw Error("frames of " + std::to_string(cell_count) + " inputs with " + std::to_string(map.extra_input_count()) +
                    " extra, expected the U-Net's glove: " + std::to_string(u->extra_inputs()) + " extra input planes");
      std::vector<float> planes(static_cast<std::size_t>(frames * values));
      for (long f = 0; f < frames; ++f)
        if (map.to_input_planes(cells + f * cell_count, planes.data() + f * values) != Status::Ok)
          throw Error("frame " + std::to_string(f) + " has a non-finite cell value, expected finite calibrated cells");
      std::vector<float> pose_maps(static_cast<std::size_t>(frames) * grid::kMapSlots);
      u->forward_batch(planes.data(), pose_maps.data(), frames, threads);
      std::array<float, grid::kMapSlots> pose_map{};
      for (long f = 0; f < frames; ++f) {
        std::copy_n(pose_maps.begin() + f * grid::kMapSlots, grid::kMapSlots, pose_map.begin());
        map.from_pose_map(pose_map, out[static_cast<std::size_t>(f)]);
      }
      return out;
    }
    if (cell_count != fcn()->inputs())
      throw Error("frames of " + std::to_string(cell_count) + " cells, expected " + std::to_string(fcn()->inputs()) +
                  " (the FCN's inputs)");
    std::vector<float> results(static_cast<std::size_t>(frames) * hand::kDofCount);
    fcn()->forward_batch(cells, results.data(), frames, threads);
    for (long f = 0; f < frames; ++f)
      for (std::size_t d = 0; d < hand::kDofCount; ++d)
        out[static_cast<std::size_t>(f)][d] = results[static_cast<std::size_t>(f) * hand::kDofCount + d];
    return out;
  }

 private:
  static_assert(nn::kFcnOutputs == static_cast<int>(hand::kDofCount), "the FCN answers one value per DoF");
  std::variant<UNet, Fcn> net_;
};

}  // namespace glovepose::model
