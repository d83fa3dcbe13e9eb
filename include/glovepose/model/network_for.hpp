/// @file network_for.hpp
/// @brief The network a PoseModel runs, built with one set of kernels: the interface PoseNetwork
/// holds (detail::Network), and its one implementation, NetworkFor<Backend>, the U-Net or the FCN
/// of a model file with Backend's kernels. Header-only use builds it with the kernels the including
/// code is compiled for; the compiled library once per instruction set, each in a unit of its own
/// (network_variants.hpp).
#pragma once

#include <array>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "../config.hpp"
#include "../core/team.hpp"
#include "../grid/grid_map.hpp"
#include "../hand/dofs.hpp"
#include "../nn/fcn.hpp"
#include "../nn/isa.hpp"
#include "../nn/unet.hpp"
#include "../status.hpp"
#include "model_info.hpp"

namespace glovepose::model::detail {

/// @brief One stream's scratch of a Network (made by Network::make_workspace).
class NetworkWorkspace {
 public:
  virtual ~NetworkWorkspace() = default;

 protected:
  explicit NetworkWorkspace(const void* kind) noexcept : kind_(kind) {}

 private:
  template <typename Backend>
  friend class NetworkFor;
  const void* kind_;  // which NetworkFor<Backend> made it
};

/// @brief A loaded U-Net or FCN with one set of kernels; immutable once built. See PoseNetwork,
/// which documents each call.
class Network {
 public:
  virtual ~Network() = default;
  /// @brief The instruction set of its kernels.
  virtual nn::Isa isa() const noexcept = 0;
  virtual Architecture architecture() const noexcept = 0;
  virtual nn::WeightStorage storage() const noexcept = 0;
  virtual std::size_t parameter_count() const noexcept = 0;
  virtual std::size_t mac_count() const noexcept = 0;
  virtual std::size_t stored_weight_count() const noexcept = 0;
  virtual std::size_t weight_bytes() const noexcept = 0;
  virtual int required_cells() const noexcept = 0;
  virtual int extra_inputs() const noexcept = 0;
  virtual int width() const noexcept = 0;
  /// @brief The U-Net with the header-only kernels (nn::UNet<>), or null (an FCN, or a network
  /// of the compiled library's variants).
  virtual const nn::UNet<>* header_only_unet() const noexcept = 0;
  /// @brief The FCN with the header-only kernels (nn::Fcn<>), or null.
  virtual const nn::Fcn<>* header_only_fcn() const noexcept = 0;
  virtual int input_values() const noexcept = 0;
  virtual std::unique_ptr<NetworkWorkspace> make_workspace(int team_size) const = 0;
  GLOVEPOSE_REALTIME virtual Status forward(const float* input, float* output, NetworkWorkspace& ws) const noexcept = 0;
  GLOVEPOSE_REALTIME virtual Status normalized_dofs(const grid::GridMap& map, const double* cells, hand::Angles& normalized,
                                                    NetworkWorkspace& ws, core::Team* team) const noexcept = 0;
  virtual std::vector<hand::Angles> normalized_dofs_batch(const grid::GridMap& map, const float* cells, int cell_count, long frames,
                                                          int threads) const = 0;
};

/// @brief The Network of nn::UNet<Backend> or nn::Fcn<Backend>.
template <typename Backend>
class NetworkFor final : public Network {
 public:
  using UNet = nn::UNet<Backend>;  ///< The U-Net with these kernels.
  using Fcn = nn::Fcn<Backend>;    ///< The FCN with these kernels.

  /// @brief The network a model file's metadata names, built from its tensors with weights kept as
  /// `storage` (set-up: throws glovepose::Error, see PoseNetwork::from_tensors).
  static std::shared_ptr<const Network> from_tensors(const ModelInfo& info, const nn::TensorMap& tensors, nn::WeightStorage storage) {
    if (info.architecture == Architecture::UNet)
      return std::make_shared<NetworkFor>(UNet::from_tensors(tensors, info.width, info.bn_eps, storage));
    if (info.architecture == Architecture::Fcn)
      return std::make_shared<NetworkFor>(Fcn::from_tensors(tensors, info.inputs, info.width, storage));
    throw Error("architecture '" + info.architecture_name() +
                "' has no real-time network, expected 'unet' or 'fcn' (train::load_model evaluates every architecture)");
  }

  explicit NetworkFor(UNet unet) : net_(std::move(unet)) {}
  explicit NetworkFor(Fcn fcn) : net_(std::move(fcn)) {}

  nn::Isa isa() const noexcept override { return nn::compiled_isa(); }
  Architecture architecture() const noexcept override { return unet() ? Architecture::UNet : Architecture::Fcn; }
  nn::WeightStorage storage() const noexcept override {
    return std::visit([](const auto& net) { return net.storage(); }, net_);
  }
  std::size_t parameter_count() const noexcept override {
    return std::visit([](const auto& net) { return net.parameter_count(); }, net_);
  }
  std::size_t mac_count() const noexcept override {
    return std::visit([](const auto& net) { return net.mac_count(); }, net_);
  }
  std::size_t stored_weight_count() const noexcept override {
    return std::visit([](const auto& net) { return net.stored_weight_count(); }, net_);
  }
  std::size_t weight_bytes() const noexcept override {
    return std::visit([](const auto& net) { return net.weight_bytes(); }, net_);
  }
  int required_cells() const noexcept override { return fcn() ? fcn()->inputs() : 0; }
  int extra_inputs() const noexcept override { return unet() ? unet()->extra_inputs() : 0; }
  int width() const noexcept override { return unet() ? unet()->width() : fcn()->hidden(); }
  int input_values() const noexcept override { return unet() ? unet()->input_values() : fcn()->inputs(); }
  const nn::UNet<>* header_only_unet() const noexcept override {
    if constexpr (std::is_same_v<UNet, nn::UNet<>>) return unet();
    return nullptr;
  }
  const nn::Fcn<>* header_only_fcn() const noexcept override {
    if constexpr (std::is_same_v<Fcn, nn::Fcn<>>) return fcn();
    return nullptr;
  }

  std::unique_ptr<NetworkWorkspace> make_workspace(int team_size) const override {
    auto ws = std::make_unique<Workspace>();
    if (const UNet* u = unet()) {
      ws->net = u->make_workspace(1, team_size);
      ws->planes.resize(static_cast<std::size_t>(u->input_values()));
    } else {
      ws->net = fcn()->make_workspace(1);
      ws->cells.resize(static_cast<std::size_t>(fcn()->inputs()));
    }
    return ws;
  }

  GLOVEPOSE_REALTIME Status forward(const float* input, float* output, NetworkWorkspace& base) const noexcept override {
    if (base.kind_ != &kKind) return Status::SizeMismatch;
    auto& ws = static_cast<Workspace&>(base);
    if (const UNet* u = unet()) {
      auto* w = std::get_if<typename UNet::Workspace>(&ws.net);
      return w ? u->forward(input, output, 1, *w) : Status::SizeMismatch;
    }
    auto* w = std::get_if<typename Fcn::Workspace>(&ws.net);
    return w ? fcn()->forward(input, output, 1, *w) : Status::SizeMismatch;
  }

  GLOVEPOSE_REALTIME Status normalized_dofs(const grid::GridMap& map, const double* cells, hand::Angles& normalized, NetworkWorkspace& base,
                                            core::Team* team) const noexcept override {
    if (base.kind_ != &kKind) return Status::SizeMismatch;
    auto& ws = static_cast<Workspace&>(base);
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

  std::vector<hand::Angles> normalized_dofs_batch(const grid::GridMap& map, const float* cells, int cell_count, long frames,
                                                  int threads) const override {
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
  static constexpr char kKind = 0;  // its address tells this class's workspaces apart

  struct Workspace final : NetworkWorkspace {
    Workspace() noexcept : NetworkWorkspace(&kKind) {}
    std::variant<typename UNet::Workspace, typename Fcn::Workspace> net;
    std::vector<float> planes;  // U-Net input: the stretch maps and the extra inputs' planes
    std::array<float, grid::kMapSlots> pose_map{};
    std::vector<float> cells;  // FCN input
    std::array<float, nn::kFcnOutputs> dofs{};
  };

  const UNet* unet() const noexcept { return std::get_if<UNet>(&net_); }
  const Fcn* fcn() const noexcept { return std::get_if<Fcn>(&net_); }

  std::variant<UNet, Fcn> net_;
};

}  // namespace glovepose::model::detail
