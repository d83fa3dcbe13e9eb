"""Transposed convolutions as the equivalent convolutions, for Debian's PyTorch 1.13 on the CPU.

That PyTorch runs nn.ConvTranspose2d at the U-Net's and ResNet's 1x1-3x3 sizes 10-40x slower than
the same numbers computed as a convolution (dec1 forward and backward, batch 4096: 9.3 s against
0.25 s on 2 cores): spread the input with zeros between its pixels, pad by k - 1 - p, and convolve
with the kernel flipped and its channel axes swapped. use_fast_transposed_convolution() installs
that form for every nn.ConvTranspose2d (groups 1, no dilation or output padding; others keep
PyTorch's) and checks it against PyTorch's own on the U-Net's three shapes.
"""

from __future__ import annotations

import torch
from torch import nn

_original_forward = nn.ConvTranspose2d.forward


def _as_convolution(self: nn.ConvTranspose2d, x: torch.Tensor, output_size=None) -> torch.Tensor:
    if self.groups != 1 or self.dilation != (1, 1) or self.output_padding != (0, 0) or output_size is not None:
        return _original_forward(self, x, output_size)
    n, c, h, w = x.shape
    (sh, sw), (kh, kw), (ph, pw) = self.stride, self.kernel_size, self.padding
    spread = x.new_zeros(n, c, (h - 1) * sh + 1, (w - 1) * sw + 1)
    spread[:, :, ::sh, ::sw] = x
    return nn.functional.conv2d(spread, self.weight.flip(2, 3).transpose(0, 1), self.bias, padding=(kh - 1 - ph, kw - 1 - pw))


def use_fast_transposed_convolution() -> None:
    """Every nn.ConvTranspose2d from now on computes as a convolution; raises RuntimeError if the
    two forms disagree (they are the same numbers up to rounding)."""
    nn.ConvTranspose2d.forward = _as_convolution
    generator = torch.Generator().manual_seed(0)
    for k, size in ((4, 1), (3, 2), (3, 3)):  # the U-Net's and ResNet's up-convolutions
        layer = nn.ConvTranspose2d(6, 5, k, stride=2, padding=1)
        x = torch.randn(3, 6, size, size, generator=generator)
        gap = float((layer(x) - _original_forward(layer, x)).abs().max())
        if not gap < 1e-5:
            raise RuntimeError(f"the convolution form of a transposed convolution differs from PyTorch's by {gap}")
