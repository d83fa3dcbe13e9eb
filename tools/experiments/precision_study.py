#!/usr/bin/env python3
"""How much precision 16-bit formats cost the U-Net, in joint-angle degrees (docs/performance.md).

Run: /usr/bin/python3 tools/experiments/precision_study.py   (needs Debian python3-torch)
A random w = 64 model (seed 21, BN statistics included), batch norm folded into the convolutions in
float64, then the folded weights and/or every convolution input rounded to F16 or BF16; outputs are
compared with the float64 forward over 256 inputs in the calibrated range [-1, 1], converted to
angles with the reference joint limits (theta 9..33, pose-map slots row = finger, column = motion).

Also the integer dot-product scheme AVX-512 VNNI (`vpdpwssd`) would need: the row products' weights
as int16 with one scale per output channel ('i16'; the first and last layers stay exact), and each
of their input rows (one grid position of one concatenated source) as 12-bit integers scaled by the
row's largest |value| ('q12'): 12 bits let 8 pairs of products accumulate in int32 before a flush
to float; 'q11' (11 bits) would let 16. Reported for the random model and for the shipped model
(models/glovepose_unet64.safetensors). For the shipped model also 12- and 8-bit integer weights
('i12', 'i8'; activations exact): what fewer bytes per weight would cost.
"""
import math
import sys
from pathlib import Path

import torch
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))  # the PyTorch reference
from glovepose_ref import UNet, randomize
from glovepose_ref.export import JOINT_LIMITS_MAX, JOINT_LIMITS_MIN, import_model
torch.manual_seed(0)
m = UNet(64); randomize(m, 21); m.eval()  # before the inputs are drawn: the seed's sequence as before
F = torch.nn.functional
ROW_PRODUCTS = range(1, 7)  # enc2..dec3: the layers whose weights the 16-bit storages code
# fold BN into convs
def fold(conv, bn, transposed):
    w = conv.weight.detach().double().clone(); b = conv.bias.detach().double().clone()
    if bn is not None:
        s = bn.weight.double() / torch.sqrt(bn.running_var.double() + bn.eps)
        b = (b - bn.running_mean.double()) * s + bn.bias.double()
        w = w * (s.view(1, -1, 1, 1) if transposed else s.view(-1, 1, 1, 1))
    return w, b
def rb(x, mode):
    if mode == 'bf16': return x.float().to(torch.bfloat16).double()
    if mode == 'f16': return x.float().half().double()
    return x
def int_per_channel(w, transposed, bits):  # 'i16', 'i12', 'i8': codes -(2^(bits-1) - 1)..2^(bits-1) - 1, one scale per output channel
    keep = [d for d in range(4) if d != (1 if transposed else 0)]
    top = 2 ** (bits - 1) - 1
    scale = w.abs().amax(dim=keep, keepdim=True).clamp_min(1e-300) / top
    return torch.round(w / scale) * scale
def quantised_rows(x, bits):  # 'q12', 'q11': each (frame, position) row over its channels, in levels of its largest |value|
    top = x.abs().amax(dim=1, keepdim=True).clamp_min(1e-300)
    levels = 2 ** bits - 1
    return torch.round(x / top * levels) * top / levels
def study(model, name, modes):
    layers = [(model.enc1, None, False), (model.enc2, model.bn2, False), (model.enc3, model.bn3, False),
              (model.enc4, model.bn4, False), (model.dec1, model.dbn1, True), (model.dec2, model.dbn2, True),
              (model.dec3, model.dbn3, True), (model.out, None, False)]
    folded = [fold(c, b, t) for c, b, t in layers]
    def fwd(x, wmode, amode):
        def conv(i, sources):
            (w, b), (c, _, t) = folded[i], layers[i]
            if wmode in ('i16', 'i12', 'i8'): w = int_per_channel(w, t, int(wmode[1:])) if i in ROW_PRODUCTS else w
            else: w = rb(w, wmode)
            if amode in ('q12', 'q11'):
                bits = int(amode[1:])
                inp = torch.cat([quantised_rows(s, bits) if i in ROW_PRODUCTS else s for s in sources], 1)
            else: inp = rb(torch.cat(sources, 1), amode)
            if t: return F.conv_transpose2d(inp, w, b, stride=c.stride, padding=c.padding)
            return F.conv2d(inp, w, b, stride=c.stride, padding=c.padding)
        e1 = F.relu(conv(0, [x])); e2 = F.relu(conv(1, [e1])); e3 = F.relu(conv(2, [e2])); e4 = F.relu(conv(3, [e3]))
        d1 = F.relu(conv(4, [e4])); d2 = F.relu(conv(5, [d1, e3])); d3 = F.relu(conv(6, [d2, e2]))
        return torch.tanh(conv(7, [d3, e1]))
    ref = fwd(x, None, None)
    for wmode, amode in modes:
        y = fwd(x, wmode, amode)
        diff = (y - ref).view(x.shape[0], 25)[:, slots].abs() * span * 180 / math.pi
        print(f"{name}: weights {wmode}, activations {amode}: max angle diff {diff.max().item():.4f} deg, mean {diff.mean().item():.5f}")
x = torch.rand(256, 2, 5, 5, dtype=torch.float64) * 2 - 1
span = torch.tensor([0.5 * (hi - lo) for lo, hi in zip(JOINT_LIMITS_MIN, JOINT_LIMITS_MAX)], dtype=torch.float64)
# pose-map slot of DoF d: row finger, column motion (thumb 9..12,29 -> row 0 cols 0..4)
slots = []
for d in range(25):
    theta = 9 + d
    if theta <= 28: f, c = (theta - 9) // 4, (theta - 9) % 4
    else: f, c = theta - 29, 4
    slots.append(f * 5 + c)
study(m, "random w = 64", [('f16', None), ('bf16', None), ('bf16', 'bf16'), ('f16', 'bf16'), ('i16', None), ('i16', 'q12')])
shipped = import_model(Path(__file__).resolve().parents[2] / "models" / "glovepose_unet64.safetensors")
study(shipped, "shipped model", [('f16', None), ('i16', None), ('i16', 'q12'), ('i16', 'q11'), ('i12', None), ('i8', None)])
