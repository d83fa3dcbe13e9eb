/// @file damped_least_squares.hpp
/// @brief The hand model's one damped least squares (Levenberg-Marquardt) loop and the derivative
/// of a point on the posed hand with respect to a DoF, shared by the keypoint fit
/// (keypoint_fit.hpp) and the contact stage (contact.hpp).
///
/// The loop: at the current parameters the problem gives the normal equations (H, g) of its cost
/// (H = J^T J plus its priors' weights, g = J^T r plus their pulls); the step solves
/// (H + lambda diag(H)) step = -g; the problem applies it (projected into the joint limits) and
/// returns the trial's cost; a trial no worse than the current cost is accepted and lambda shrinks
/// (/3, at least 1e-9), else lambda grows (x4) and the step is solved again, up to lambda 1e8. It
/// stops after max_iterations, when no step is accepted, or when the accepted step's largest
/// component is below step_tolerance. Fixed-size matrices: no allocation.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>

#include <Eigen/Dense>

#include "../config.hpp"
#include "dofs.hpp"
#include "kinematics.hpp"

namespace glovepose::hand {

/// @brief d(point)/d(angle of DoF `dof`) of a point carried by that DoF's phalanx or one after it:
/// the DoF's axis (from Kinematics::pose with axes) crossed with the arm from the phalanx's origin.
GLOVEPOSE_REALTIME inline Eigen::Vector3d dof_derivative(const DofAxes& axes, const Skeleton& skeleton, std::size_t dof,
                                                         const Eigen::Vector3d& point) noexcept {
  return axes[dof].cross(point - skeleton[static_cast<std::size_t>(kDofs[dof].phalanx)].translation());
}

/// @brief Minimizes a problem of P parameters by the loop of the file comment, from `cost` (the
/// current parameters' cost; on return the last accepted one's). `normal_equations(h, g)` fills
/// H and g (zeroed) at the current parameters; `trial(step)` applies a step to a copy of them and
/// returns its cost (non-finite: refused); `accept()` makes the last trial current. Returns the
/// iterations run.
template <int P, typename NormalEquations, typename Trial, typename Accept>
GLOVEPOSE_REALTIME int damped_least_squares(double& cost, int max_iterations, double step_tolerance, NormalEquations&& normal_equations,
                                            Trial&& trial, Accept&& accept) noexcept {
  double lambda = 1e-3;
  int iteration = 0;
  for (; iteration < max_iterations; ++iteration) {
    Eigen::Matrix<double, P, P> h = Eigen::Matrix<double, P, P>::Zero();
    Eigen::Matrix<double, P, 1> g = Eigen::Matrix<double, P, 1>::Zero();
    normal_equations(h, g);
    bool accepted = false;
    double moved = 0.0;
    while (!accepted && lambda < 1e8) {
      Eigen::Matrix<double, P, P> damped = h;
      for (int i = 0; i < P; ++i) damped(i, i) += lambda * (h(i, i) + 1e-9);
      const Eigen::Matrix<double, P, 1> step = -damped.ldlt().solve(g);
      const double candidate = trial(step);
      if (std::isfinite(candidate) && candidate <= cost) {
        moved = step.cwiseAbs().maxCoeff();
        accept();
        cost = candidate;
        lambda = std::max(lambda / 3.0, 1e-9);
        accepted = true;
      } else {
        lambda *= 4.0;
      }
    }
    if (!accepted) break;
    if (moved < step_tolerance) break;
  }
  return iteration;
}

}  // namespace glovepose::hand
