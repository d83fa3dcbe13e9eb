#!/usr/bin/env python3
"""How much precision 16-bit formats cost the U-Net, in joint-angle degrees (docs/performance.md).

Run: /usr/bin/python3 tools/python/precision_study.py   (needs Debian python3-torch)
A random w = 64 model (seed 21, BN statistics included), batch norm folded into the convolutions in
float64, then the folded weights and/or every convolution input rounded to F16 or BF16; outputs are
compared with the float64 forward over 256 inputs in the calibrated range [-1, 1], converted to
angles with the reference joint limits (theta 9..33, pose-map slots row = finger, column = motion).
"""
import math
import sys
from pathlib import Path

import torch
sys.path.insert(0, str(Path(__file__).resolve().parent))
from glovepose_ref import UNet, randomize
from glovepose_ref.export import JOINT_LIMITS_MAX, JOINT_LIMITS_MIN
torch.manual_seed(0)
m = UNet(64); randomize(m, 21); m.eval()
# fold BN into convs
def fold(conv, bn, transposed):
    w = conv.weight.detach().double().clone(); b = conv.bias.detach().double().clone()
    if bn is not None:
        s = bn.weight.double() / torch.sqrt(bn.running_var.double() + bn.eps)
        b = (b - bn.running_mean.double()) * s + bn.bias.double()
        w = w * (s.view(1, -1, 1, 1) if transposed else s.view(-1, 1, 1, 1))
    return w, b
layers = [(m.enc1, None, False), (m.enc2, m.bn2, False), (m.enc3, m.bn3, False), (m.enc4, m.bn4, False),
          (m.dec1, m.dbn1, True), (m.dec2, m.dbn2, True), (m.dec3, m.dbn3, True), (m.out, None, False)]
folded = [fold(c, b, t) for c, b, t in layers]
def rb(x, mode):
    if mode == 'bf16': return x.float().to(torch.bfloat16).double()
    if mode == 'f16': return x.float().half().double()
    return x
def fwd(x, wmode, amode):
    F = torch.nn.functional
    def conv(i, inp):
        (w, b), (c, _, t) = folded[i], layers[i]
        w = rb(w, wmode); inp = rb(inp, amode)
        if t: return F.conv_transpose2d(inp, w, b, stride=c.stride, padding=c.padding)
        return F.conv2d(inp, w, b, stride=c.stride, padding=c.padding)
    e1 = F.relu(conv(0, x)); e2 = F.relu(conv(1, e1)); e3 = F.relu(conv(2, e2)); e4 = F.relu(conv(3, e3))
    d1 = F.relu(conv(4, e4)); d2 = F.relu(conv(5, torch.cat([d1, e3], 1))); d3 = F.relu(conv(6, torch.cat([d2, e2], 1)))
    return torch.tanh(conv(7, torch.cat([d3, e1], 1)))
x = torch.rand(256, 2, 5, 5, dtype=torch.float64) * 2 - 1
ref = fwd(x, None, None)
span = torch.tensor([0.5 * (hi - lo) for lo, hi in zip(JOINT_LIMITS_MIN, JOINT_LIMITS_MAX)], dtype=torch.float64)
# pose-map slot of DoF d: row finger, column motion (thumb 9..12,29 -> row 0 cols 0..4)
slots = []
for d in range(25):
    theta = 9 + d
    if theta <= 28: f, c = (theta - 9) // 4, (theta - 9) % 4
    else: f, c = theta - 29, 4
    slots.append(f * 5 + c)
for wmode, amode in [('f16', None), ('bf16', None), ('bf16', 'bf16'), ('f16', 'bf16')]:
    y = fwd(x, wmode, amode)
    diff = (y - ref).view(256, 25)[:, slots].abs() * span * 180 / math.pi
    print(f"weights {wmode}, activations {amode}: max angle diff {diff.max().item():.4f} deg, mean {diff.mean().item():.5f}")
