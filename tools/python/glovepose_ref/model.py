"""The glovepose U-Net (paper Table 6) in PyTorch, with the tensor names of weights_format.md.

Input [N, 2 + E, 5, 5] (channel 0 "along", channel 1 "across" stretch map; for a glove with E extra
inputs -- cells marked "extra", not on the maps -- channel 2 + k is a constant 5x5 plane filled with
the calibrated value of the k-th extra input, extra inputs in the glove description's input order),
output [N, 1, 5, 5] in [-1, 1] (the pose map: rows fingers, columns abduction, base, middle, tip
flexion, twist). E changes only enc1 (weight [w, 2 + E, 5, 5]); E = 0 is the paper's network.

Spatial sizes: enc1 5 -> 5, enc2 5 -> 3, enc3 3 -> 2, enc4 2 -> 1, dec1 1 -> 2, dec2 2 -> 3,
dec3 3 -> 5, out 5 -> 5. Skip connections concatenate [decoder, encoder] along channels.

Run `/usr/bin/python3 -m glovepose_ref.model` (from tools/python) to print the parameter counts of
the presets.
"""

from __future__ import annotations

from typing import Callable, Dict, Iterable

import torch
from torch import nn

#: Named widths (nn::UNetPreset on the C++ side).
PRESETS: Dict[str, int] = {"paper3m": 48, "paper13m": 100, "paper50m": 196, "w64": 64}

#: The BatchNorm layers, in forward order.
BN_NAMES = ("bn2", "bn3", "bn4", "dbn1", "dbn2", "dbn3")
#: The convolutions (Conv2d and ConvTranspose2d), in forward order.
CONV_NAMES = ("enc1", "enc2", "enc3", "enc4", "dec1", "dec2", "dec3", "out")


class UNet(nn.Module):
    """U-Net of base width `width` (the paper: 64) reading 2 + `extra_inputs` input planes.

    State-dict keys match weights_format.md. extra_inputs E: the glove's inputs that are not on the
    stretch maps, each read as a constant 5x5 plane (channels 2..2 + E - 1, in the glove's input
    order); only enc1's weight changes shape ([width, 2 + E, 5, 5]). E = 0: the paper's U-Net.
    """

    reads_maps = True  # train_torch.Pipeline scatters the cells into the stretch maps for it

    def __init__(self, width: int = 64, extra_inputs: int = 0) -> None:
        super().__init__()
        if width < 1:
            raise ValueError(f"UNet: width {width}, expected >= 1")
        if extra_inputs < 0:
            raise ValueError(f"UNet: extra_inputs {extra_inputs}, expected >= 0")
        w = width
        self.width = width
        self.extra_inputs = extra_inputs
        self.enc1 = nn.Conv2d(2 + extra_inputs, w, 5, stride=1, padding=2)
        self.enc2 = nn.Conv2d(w, 2 * w, 3, stride=2, padding=1)
        self.bn2 = nn.BatchNorm2d(2 * w)
        self.enc3 = nn.Conv2d(2 * w, 4 * w, 3, stride=2, padding=1)
        self.bn3 = nn.BatchNorm2d(4 * w)
        self.enc4 = nn.Conv2d(4 * w, 8 * w, 4, stride=2, padding=1)
        self.bn4 = nn.BatchNorm2d(8 * w)
        self.dec1 = nn.ConvTranspose2d(8 * w, 4 * w, 4, stride=2, padding=1)
        self.dbn1 = nn.BatchNorm2d(4 * w)
        self.dec2 = nn.ConvTranspose2d(8 * w, 2 * w, 3, stride=2, padding=1)
        self.dbn2 = nn.BatchNorm2d(2 * w)
        self.dec3 = nn.ConvTranspose2d(4 * w, w, 3, stride=2, padding=1)
        self.dbn3 = nn.BatchNorm2d(w)
        self.out = nn.Conv2d(2 * w, 1, 5, stride=1, padding=2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """[N, 2 + extra_inputs, 5, 5] -> [N, 1, 5, 5]."""
        relu = torch.relu
        e1 = relu(self.enc1(x))                                      # w  x 5x5
        e2 = relu(self.bn2(self.enc2(e1)))                           # 2w x 3x3
        e3 = relu(self.bn3(self.enc3(e2)))                           # 4w x 2x2
        e4 = relu(self.bn4(self.enc4(e3)))                           # 8w x 1x1
        d1 = relu(self.dbn1(self.dec1(e4)))                          # 4w x 2x2
        d2 = relu(self.dbn2(self.dec2(torch.cat([d1, e3], 1))))      # 2w x 3x3
        d3 = relu(self.dbn3(self.dec3(torch.cat([d2, e2], 1))))      # w  x 5x5
        return torch.tanh(self.out(torch.cat([d3, e1], 1)))          # 1  x 5x5


def count_parameters(model: nn.Module) -> Dict[str, int]:
    """Counts of a model's numbers.

    Keys: `conv_weights` (convolution weights only; 5,306,624 for w = 64), `biases`, `bn_affine`
    (BN weight + bias), `learnable` (all trainable parameters), `bn_running` (running mean + var),
    `stored` (every number in a model file: learnable + bn_running).
    """
    sd = model.state_dict()

    def total(keys: Iterable[str]) -> int:
        return sum(sd[k].numel() for k in keys)

    conv_w = total(f"{n}.weight" for n in CONV_NAMES)
    biases = total(f"{n}.bias" for n in CONV_NAMES)
    bn_aff = total(f"{n}.{p}" for n in BN_NAMES for p in ("weight", "bias"))
    bn_run = total(f"{n}.{p}" for n in BN_NAMES for p in ("running_mean", "running_var"))
    learnable = sum(p.numel() for p in model.parameters())
    assert learnable == conv_w + biases + bn_aff
    return {
        "conv_weights": conv_w,
        "biases": biases,
        "bn_affine": bn_aff,
        "learnable": learnable,
        "bn_running": bn_run,
        "stored": learnable + bn_run,
    }


def seeded_uniform(seed: int) -> Callable[[torch.Tensor, float, float], None]:
    """A filler t <- U(lo, hi), drawn in float64 from one torch.Generator seeded `seed` and rounded to
    t's dtype; successive calls continue the same stream (randomize and fcn.randomize_fcn use it)."""
    g = torch.Generator().manual_seed(int(seed))

    def uniform_(t: torch.Tensor, lo: float, hi: float) -> None:
        t.copy_(torch.rand(t.shape, generator=g, dtype=torch.float64).mul_(hi - lo).add_(lo).to(t.dtype))

    return uniform_


def randomize(model: UNet, seed: int) -> UNet:
    """Fills every weight and BN statistic with deterministic random values (for tests); returns model.

    Convolution weights Xavier-uniform, biases U(-0.1, 0.1), BN weight U(0.5, 1.5), BN bias
    U(-0.2, 0.2), running_mean U(-0.2, 0.2), running_var U(0.5, 2.0). The values depend only on
    `seed`, the width and extra_inputs (one torch.Generator, layers visited in forward order; with
    extra inputs enc1's weight takes more draws and its Xavier bound uses fan_in (2 + E) * 25, so
    every later value differs from the E = 0 network's; E = 0 draws exactly as before E existed).
    """
    uniform_ = seeded_uniform(seed)

    with torch.no_grad():
        for name in CONV_NAMES:
            conv = getattr(model, name)
            # Xavier-uniform as nn.init.xavier_uniform_ computes it (fan_in = size(1) * k * k,
            # fan_out = size(0) * k * k of the stored weight), but drawn from our generator.
            w = conv.weight
            receptive = w[0][0].numel()
            fan_in, fan_out = w.shape[1] * receptive, w.shape[0] * receptive
            a = (6.0 / (fan_in + fan_out)) ** 0.5
            uniform_(w, -a, a)
            uniform_(conv.bias, -0.1, 0.1)
        for name in BN_NAMES:
            bn = getattr(model, name)
            uniform_(bn.weight, 0.5, 1.5)
            uniform_(bn.bias, -0.2, 0.2)
            uniform_(bn.running_mean, -0.2, 0.2)
            uniform_(bn.running_var, 0.5, 2.0)
    return model


def _main() -> None:
    print(f"{'preset':<10} {'width':>5} {'conv weights':>13} {'biases':>7} {'BN affine':>10} {'learnable':>11} {'BN running':>11} {'stored':>11}")
    for name, width in PRESETS.items():
        c = count_parameters(UNet(width))
        print(
            f"{name:<10} {width:>5} {c['conv_weights']:>13,} {c['biases']:>7,} {c['bn_affine']:>10,} "
            f"{c['learnable']:>11,} {c['bn_running']:>11,} {c['stored']:>11,}"
        )


if __name__ == "__main__":
    _main()
