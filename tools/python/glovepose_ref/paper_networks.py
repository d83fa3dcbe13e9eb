"""The paper's other networks of Sec. 5.4 (appendix A) in PyTorch: LSTM, ResNet and the CGAN's
discriminator (its generator is the U-Net of model.py). glovepose does not run these at run time;
they exist to re-run the paper's Tables 4 and 5 (tools/experiments/torch_networks.py).

Appendix A describes each at 13M parameters and says the other sizes keep the structure with other
numbers or sizes of layers; `sized(kind, params)` picks the width that comes closest to a parameter
count, as the experiments do for the FCN.

    LSTMRegressor(inputs, hidden)  two LSTM layers of `hidden` features over a window of frames
                                   [N, T, inputs] (the paper: T = 5, hidden 512), then a linear
                                   layer from the last step to the 25 DoFs (no output activation,
                                   like the FCN)
    ResNetMaps(channels, E)        the stretch maps [N, 2 + E, 5, 5] -> a stride-2 convolution
                                   (5x5 -> 3x3), 12 residual blocks (conv3x3-BN-ReLU-conv3x3-BN,
                                   added to the input, ReLU), a stride-2 up-convolution (3x3 -> 5x5)
                                   and a 5x5 convolution to the pose map [N, 1, 5, 5] in [-1, 1]
    PatchDiscriminator(width, c)   the CGAN's D: C64-C128-C256-C512-C1 over the input maps and a
                                   pose map concatenated [N, c, 5, 5]; pix2pix's patch discriminator
                                   (stride 2 in the first three layers, 1 in the last two; LeakyReLU
                                   0.2; BN after all but the first and last) with 3x3 kernels, which
                                   fit the 5x5 maps (5 -> 3 -> 2 -> 1): a logit [N, 1, 1, 1]
"""

from __future__ import annotations

from torch import nn
import torch

from .fcn import FCN
from .model import UNet


class LSTMRegressor(nn.Module):
    """Two-layer LSTM over the last T frames of calibrated cells -> 25 normalised DoFs."""

    reads_maps = False

    def __init__(self, inputs: int = 44, hidden: int = 512, outputs: int = 25, layers: int = 2) -> None:
        super().__init__()
        self.lstm = nn.LSTM(inputs, hidden, num_layers=layers, batch_first=True)
        self.head = nn.Linear(hidden, outputs)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """[N, T, inputs] -> [N, outputs] (the prediction for the window's last frame)."""
        out, _ = self.lstm(x)
        return self.head(out[:, -1])


class ResidualBlock(nn.Module):
    def __init__(self, channels: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(channels, channels, 3, padding=1)
        self.bn1 = nn.BatchNorm2d(channels)
        self.conv2 = nn.Conv2d(channels, channels, 3, padding=1)
        self.bn2 = nn.BatchNorm2d(channels)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = torch.relu(self.bn1(self.conv1(x)))
        return torch.relu(x + self.bn2(self.conv2(y)))


class ResNetMaps(nn.Module):
    """Stretch maps -> pose map through a stride-2 encoder, residual blocks and a stride-2 decoder."""

    reads_maps = True

    def __init__(self, channels: int = 128, extra_inputs: int = 0, blocks: int = 12) -> None:
        super().__init__()
        c = channels
        self.extra_inputs = extra_inputs
        self.down = nn.Conv2d(2 + extra_inputs, c, 3, stride=2, padding=1)  # 5x5 -> 3x3
        self.bn_down = nn.BatchNorm2d(c)
        self.blocks = nn.Sequential(*[ResidualBlock(c) for _ in range(blocks)])
        self.up = nn.ConvTranspose2d(c, c, 3, stride=2, padding=1)  # 3x3 -> 5x5
        self.bn_up = nn.BatchNorm2d(c)
        self.out = nn.Conv2d(c, 1, 5, padding=2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """[N, 2 + E, 5, 5] -> [N, 1, 5, 5]."""
        y = torch.relu(self.bn_down(self.down(x)))
        y = self.blocks(y)
        y = torch.relu(self.bn_up(self.up(y)))
        return torch.tanh(self.out(y))


class PatchDiscriminator(nn.Module):
    """The CGAN's discriminator: is this pose map the one that belongs to these stretch maps?"""

    def __init__(self, width: int = 64, in_channels: int = 3) -> None:
        super().__init__()
        w = width
        self.net = nn.Sequential(
            nn.Conv2d(in_channels, w, 3, stride=2, padding=1), nn.LeakyReLU(0.2),
            nn.Conv2d(w, 2 * w, 3, stride=2, padding=1), nn.BatchNorm2d(2 * w), nn.LeakyReLU(0.2),
            nn.Conv2d(2 * w, 4 * w, 3, stride=2, padding=1), nn.BatchNorm2d(4 * w), nn.LeakyReLU(0.2),
            nn.Conv2d(4 * w, 8 * w, 3, padding=1), nn.BatchNorm2d(8 * w), nn.LeakyReLU(0.2),
            nn.Conv2d(8 * w, 1, 3, padding=1),
        )

    def forward(self, maps: torch.Tensor, pose: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([maps, pose], 1))


def parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())


def build(kind: str, size: int, inputs: int = 44, extra_inputs: int = 0) -> nn.Module:
    """The network `kind` (fcn, lstm, resnet, unet; cgan = its U-Net generator) of width `size`."""
    if kind == "fcn":
        return FCN(inputs, size, 25)
    if kind == "lstm":
        return LSTMRegressor(inputs, size)
    if kind == "resnet":
        return ResNetMaps(size, extra_inputs)
    if kind in ("unet", "cgan"):
        return UNet(size, extra_inputs)
    raise ValueError(f"network {kind!r}, expected fcn, lstm, resnet, unet or cgan")


def sized(kind: str, params: float, inputs: int = 44) -> int:
    """The width of network `kind` whose parameter count comes closest to `params` (for the CGAN,
    its generator's: the discriminator is not run after training)."""
    hi = 8
    while parameters(build(kind, hi, inputs)) < params:  # counts grow with the width: bracket, bisect
        hi *= 2
    lo = 2
    while lo < hi:
        mid = (lo + hi) // 2
        if parameters(build(kind, mid, inputs)) < params:
            lo = mid + 1
        else:
            hi = mid
    candidates = [w for w in (lo - 1, lo) if w >= 2]
    return min(candidates, key=lambda w: abs(parameters(build(kind, w, inputs)) - params))
