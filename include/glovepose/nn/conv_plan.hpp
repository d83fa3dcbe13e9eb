/// @file conv_plan.hpp
/// @brief Which kernel taps of a convolution or transposed convolution ever meet real input on a
/// fixed, small grid, and which output/input positions each of them joins.
///
/// On the U-Net's 5x5-and-smaller grids many taps only ever meet zero padding (12 of the 16 taps
/// of the 4x4 convolutions); a plan lists the useful (tap, output position, input position)
/// triples once, at load, so the weights of the other taps are neither stored nor read.
#pragma once

#include <string>
#include <vector>

#include "../config.hpp"

namespace glovepose::nn {

/// @brief Geometry of a square 2D convolution on a square grid.
struct ConvGeometry {
  int in_size;      ///< Input height = width.
  int out_size;     ///< Output height = width.
  int kernel;       ///< Kernel height = width.
  int stride;       ///< Stride.
  int padding;      ///< Zero padding on each side.
  bool transposed;  ///< Transposed ("up") convolution, PyTorch's ConvTranspose2d (output_padding 0).

  /// @brief Throws glovepose::Error unless out_size follows from the other fields as in PyTorch.
  void validate(const std::string& layer) const {
    const int expected = transposed ? (in_size - 1) * stride - 2 * padding + kernel : (in_size + 2 * padding - kernel) / stride + 1;
    if (in_size < 1 || kernel < 1 || stride < 1 || padding < 0 || out_size != expected)
      throw Error("ConvGeometry: layer " + layer + " maps " + std::to_string(in_size) + " to " + std::to_string(out_size) +
                  " with kernel " + std::to_string(kernel) + ", stride " + std::to_string(stride) + ", padding " + std::to_string(padding) +
                  ", expected output size " + std::to_string(expected));
  }
};

/// @brief One useful tap and the (output, input) position pairs it joins. Positions are flat
/// (row * size + column); each output position appears at most once per tap.
struct TapPairs {
  int tap;                         ///< ky * kernel + kx.
  std::vector<int> out_positions;  ///< Output positions, ascending.
  std::vector<int> in_positions;   ///< The input position joined to each output position.
};

/// @brief The useful taps of a geometry, in ascending tap order.
inline std::vector<TapPairs> plan_taps(const ConvGeometry& g) {
  std::vector<TapPairs> taps;
  for (int ky = 0; ky < g.kernel; ++ky)
    for (int kx = 0; kx < g.kernel; ++kx) {
      TapPairs t{ky * g.kernel + kx, {}, {}};
      for (int oy = 0; oy < g.out_size; ++oy)
        for (int ox = 0; ox < g.out_size; ++ox) {
          int iy = 0, ix = 0;
          if (!g.transposed) {  // out(o) += w(k) in(o * s - p + k)
            iy = oy * g.stride - g.padding + ky;
            ix = ox * g.stride - g.padding + kx;
          } else {  // out(i * s - p + k) += w(k) in(i): solve for i
            const int ny = oy + g.padding - ky, nx = ox + g.padding - kx;
            if (ny < 0 || nx < 0 || ny % g.stride != 0 || nx % g.stride != 0) continue;
            iy = ny / g.stride;
            ix = nx / g.stride;
          }
          if (iy < 0 || iy >= g.in_size || ix < 0 || ix >= g.in_size) continue;
          t.out_positions.push_back(oy * g.out_size + ox);
          t.in_positions.push_back(iy * g.in_size + ix);
        }
      if (!t.out_positions.empty()) taps.push_back(std::move(t));
    }
  return taps;
}

}  // namespace glovepose::nn
