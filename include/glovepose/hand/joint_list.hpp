/// @file joint_list.hpp
/// @brief Fills the 21-joint list (joint_list_types.hpp: the joints, their order and conventions)
/// from a posed skeleton.
#pragma once

#include <array>
#include <cstddef>

#include <Eigen/Geometry>

#include "../config.hpp"
#include "joint_list_types.hpp"
#include "kinematics.hpp"

namespace glovepose::hand {

/// @brief Fills the joint list from a posed skeleton (Kinematics::pose) of the same kinematics.
GLOVEPOSE_REALTIME inline void to_joint_list(const Kinematics& kinematics, const Skeleton& skeleton, JointList& out) noexcept {
  const auto put = [&](std::size_t joint, const Eigen::Affine3d& frame, const Eigen::Vector3d& position) {
    const Eigen::Quaterniond q(frame.linear());
    out[joint].position = {static_cast<float>(position.x() * 1e-3), static_cast<float>(position.y() * 1e-3),
                           static_cast<float>(position.z() * 1e-3)};
    out[joint].rotation = {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), static_cast<float>(q.w())};
  };
  const Eigen::Affine3d& palm = skeleton[static_cast<std::size_t>(Phalanx::Hand)];
  put(0, palm, palm.translation());
  for (std::size_t f = 0; f < kFingerCount; ++f) {
    const auto base = static_cast<std::size_t>(kFingerBase[f]);
    const std::size_t first = 1 + 4 * f;
    for (std::size_t k = 0; k < 3; ++k) put(first + k, skeleton[base + k], skeleton[base + k].translation());
    put(first + 3, skeleton[base + 2], kinematics.fingertip(skeleton, static_cast<Finger>(f)));
  }
}

}  // namespace glovepose::hand
