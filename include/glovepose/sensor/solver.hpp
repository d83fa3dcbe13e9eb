/// @file solver.hpp
/// @brief Least-squares cell capacitances C_c from the compound measurements C_m (M C_c = C_m).
///
/// M is fixed by the glove, so its QR factorisation is computed once at construction and folded
/// into the least-squares solution operator P = R^-1 Q^T (cells x rows); a frame is then one
/// matrix-vector product, C_c = P C_m, which is what back-substitution with the stored QR factors
/// computes, at a fixed and small cost (44 x 180 multiply-adds for the paper's glove).
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "../config.hpp"
#include "../status.hpp"
#include "layout.hpp"

namespace glovepose::sensor {

/// @brief Solves M C_c = C_m in the least-squares sense for a fixed layout.
///
/// Sizes are the layout's, at run time: sizes fixed at compile time made the paper's glove no faster
/// (BM_CapacitanceSolve 0.93x, BM_ReadoutFrameOfRows 1.03x of the fixed-size times, same run).
/// Immutable after construction: one solver may be shared by any number of streams and threads.
class CapacitanceSolver {
 public:
  /// @brief One frame of compound measurements C_m (one value per row of M).
  using Measurements = Eigen::VectorXd;
  /// @brief One frame of cell capacitances C_c.
  using Capacitances = Eigen::VectorXd;
  /// @brief The solution operator P (cells x rows).
  using Operator = Eigen::MatrixXd;

  /// @brief Factorises the layout's M. Throws glovepose::Error when M has more cells than rows or is
  /// rank-deficient (naming cells that cannot be told apart).
  explicit CapacitanceSolver(const TraceLayout& layout) : layout_(layout), m_(layout.measurement_matrix()) {
    if (layout.cell_count() > layout.row_count())
      throw Error("CapacitanceSolver: layout '" + layout.id() + "' has more cells (" + std::to_string(layout.cell_count()) +
                  ") than measurements (" + std::to_string(layout.row_count()) + "), expected at most one cell per measurement");

    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(m_);
    if (qr.rank() < layout.cell_count()) throw Error(rank_deficiency_message(layout, qr));

    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(m_);
    const auto& s = svd.singularValues();
    condition_number_ = s(0) / s(s.size() - 1);

    // P = R^-1 Q^T (with the column permutation): the least-squares solution of M x = e_k for each
    // unit vector e_k of the measurement space.
    const Eigen::MatrixXd p = qr.solve(Eigen::MatrixXd::Identity(layout.row_count(), layout.row_count()));
    operator_ = p;
  }

  /// @brief Solves one frame: `cells` = argmin |M cells - measurements|.
  ///
  /// Returns Status::SizeMismatch or Status::NonFinite without touching
  /// `cells`; Status::Ok otherwise. Never allocates.
  GLOVEPOSE_REALTIME Status solve(const Measurements& measurements, Capacitances& cells) const noexcept {
    if (measurements.size() != operator_.cols() || cells.size() != operator_.rows()) return Status::SizeMismatch;
    if (!measurements.allFinite()) return Status::NonFinite;
    cells.noalias() = operator_ * measurements;
    return Status::Ok;
  }

  /// @brief The layout the solver was built for.
  const TraceLayout& layout() const noexcept { return layout_; }
  /// @brief The measurement matrix M.
  const Eigen::MatrixXd& measurement_matrix() const noexcept { return m_; }
  /// @brief The least-squares solution operator P = (M^T M)^-1 M^T.
  const Operator& solution_operator() const noexcept { return operator_; }
  /// @brief 2-norm condition number of M (largest over smallest singular value): how much relative
  /// measurement noise is amplified in the solved capacitances, at worst.
  double condition_number() const noexcept { return condition_number_; }

 private:
  static std::string rank_deficiency_message(const TraceLayout& layout, const Eigen::ColPivHouseholderQR<Eigen::MatrixXd>& qr) {
    // Cells with weight in the null space of M are the ones whose capacitances trade off unseen.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(layout.measurement_matrix(), Eigen::ComputeFullV);
    const Eigen::Index rank = qr.rank();
    std::string cells;
    for (int c = 0; c < layout.cell_count(); ++c) {
      const double weight = svd.matrixV().row(c).tail(layout.cell_count() - rank).norm();
      if (weight > 1e-6) cells += (cells.empty() ? "" : ", ") + std::to_string(c);
    }
    return "CapacitanceSolver: the measurement matrix of layout '" + layout.id() + "' has rank " + std::to_string(rank) + " but " +
           std::to_string(layout.cell_count()) + " cells, expected full column rank; these cells cannot be told apart: " + cells;
  }

  TraceLayout layout_;
  Eigen::MatrixXd m_;
  Operator operator_;
  double condition_number_ = 0.0;
};

}  // namespace glovepose::sensor
