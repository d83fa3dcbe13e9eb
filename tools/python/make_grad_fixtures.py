#!/usr/bin/env python3
"""Writes a PyTorch reference of one training step (forward, MSE loss, backward, BN running
statistics, one Adam step) for the C++ trainer's tests.

Usage: /usr/bin/python3 tools/python/make_grad_fixtures.py --arch unet:W[:E] --batch B --seed S --out FILE
       /usr/bin/python3 tools/python/make_grad_fixtures.py --arch fcn:H:C --batch B --seed S --out FILE

    --arch unet:W[:E] randomize(UNet(W, E), S)                   input [B, 2 + E, 5, 5], target [B, 1, 5, 5]
                      (E: the glove's extra inputs, one input plane each; default 0)
    --arch fcn:H:C    randomize_fcn(FCN(C, H, 25), S)            input [B, C],           target [B, 25]

The fixtures in tests/fixtures were made with
    --arch unet:4    --batch 8 --seed 3 --out tests/fixtures/grad_unet_w4.safetensors
    --arch fcn:16:44 --batch 8 --seed 4 --out tests/fixtures/grad_fcn_h16_c44.safetensors
    --arch unet:4:2  --batch 8 --seed 6 --out tests/fixtures/grad_unet_w4_e2.safetensors

Procedure:
  1. The model is randomized in float32 (glovepose_ref.randomize / randomize_fcn with seed S), then
     converted with .double() and put in TRAIN mode, so the float64 computation starts from exactly
     the F32 values stored as `param.*`.
  2. input  = U(-1.2, 1.2) from torch.Generator seeded S + 1000003, drawn in float64, rounded to F32;
     target = U(-1, 1)    from torch.Generator seeded S + 2000003, drawn in float64, rounded to F32.
     The computation uses the F32 values widened to float64.
  3. output = model(input) (train mode: BN normalises with the batch mean and the biased batch
     variance, eps 1e-5, and updates its running statistics with momentum 0.1 and the UNBIASED batch
     variance: running = 0.9 * running + 0.1 * batch_stat);
     loss = torch.nn.functional.mse_loss(output, target) = mean over all B * 25 elements of
     (output - target)^2; loss.backward().
  4. One torch.optim.Adam step (lr 2e-4, betas (0.5, 0.999), eps 1e-8, weight_decay 0, amsgrad off)
     on those gradients from the starting parameters. At step 1 PyTorch computes
         m = (1 - b1) g,  v = (1 - b2) g^2,
         p -= lr / (1 - b1) * m / (sqrt(v) / sqrt(1 - b2) + eps)
     i.e. p -= lr * g / (|g| + eps) up to rounding.
  Everything after step 1 is float64.

File layout (glovepose safetensors container, tensors sorted by name; <p> runs over the learnable
parameters, i.e. the state_dict names of model.parameters(); <bn> over the BatchNorm layers, U-Net
only: bn2 bn3 bn4 dbn1 dbn2 dbn3):
    input                        F32  [B, 2 + E, 5, 5] | [B, C]   (every value drawn independently)
    target                       F32  [B, 1, 5, 5] | [B, 25]
    output                       F64  [B, 1, 5, 5] | [B, 25]   train-mode forward
    loss                         F64  [1]
    param.<p>                    F32  shape of <p>   starting value
    param.<bn>.running_mean      F32  [channels]     starting value
    param.<bn>.running_var       F32  [channels]     starting value
    grad.<p>                     F64  shape of <p>   d loss / d <p>
    after.<bn>.running_mean      F64  [channels]     after the one training forward
    after.<bn>.running_var       F64  [channels]
    adam.<p>                     F64  shape of <p>   <p> after one Adam step
(`num_batches_tracked` is not stored.) U-Net <p>: <conv>.weight, <conv>.bias for enc1 enc2 enc3 enc4
dec1 dec2 dec3 out, <bn>.weight, <bn>.bias; FCN <p>: fc1..fc6 .weight [out, in] and .bias [out].

Metadata (strings): format "glovepose-grad-fixture", format_version "1", arch "unet" | "fcn",
width and extra_inputs (U-Net; extra_inputs only when E > 0, so E = 0 files are as before) or
hidden/inputs/outputs (FCN), batch, seed, input_seed, target_seed, input_range,
target_range, mode "train", compute_dtype "float64", loss, optimizer (JSON with lr, beta1, beta2, eps,
weight_decay, amsgrad, steps), bn_momentum, bn_eps, bn_running_var, torch_version,
zero_grad_params (JSON list of the <p> whose float64 gradient is below 1e-12 everywhere, i.e. exactly
0 up to round-off), and torch_f32_max_abs_diff: JSON with the largest |difference| between the same
step done by PyTorch in float32 and the stored float64 reference, per group (output, loss, grad,
after (U-Net only), adam over the other parameters, adam_zero_grad_params) -- a hint of what an F32
implementation can reach.

Note: in the U-Net every convolution followed by a BatchNorm in train mode (enc2..enc4, dec1..dec3)
has a bias whose exact gradient is 0 (BN subtracts the batch mean); the stored grad.* of those biases
is float64 round-off (~1e-17) and their adam.* equals param.* to ~1e-13, but an F32 implementation's
round-off gradient (~1e-8, comparable to Adam's eps) can move them by a good fraction of lr = 2e-4
(PyTorch's own F32 step does: see torch_f32_max_abs_diff.adam_zero_grad_params). Compare those
adam.* with a tolerance of ~lr, or skip them.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path
from typing import Dict, List, Tuple

sys.path.insert(0, str(Path(__file__).resolve().parent))

import torch  # noqa: E402
from torch import nn  # noqa: E402

from glovepose_ref import FCN, UNet, randomize, randomize_fcn, safetensors_io  # noqa: E402

FORMAT = "glovepose-grad-fixture"
FORMAT_VERSION = "1"
INPUT_SEED_OFFSET = 1000003
TARGET_SEED_OFFSET = 2000003
INPUT_RANGE = 1.2
TARGET_RANGE = 1.0
FCN_OUTPUTS = 25
ADAM = {"lr": 2e-4, "beta1": 0.5, "beta2": 0.999, "eps": 1e-8, "weight_decay": 0.0}
BN_MOMENTUM = 0.1
BN_EPS = 1e-5
#: A float64 gradient below this everywhere is taken as exactly 0 (round-off of a vanishing sum).
ZERO_GRAD = 1e-12


def parse_arch(spec: str) -> Tuple[str, Dict[str, int]]:
    """'unet:W' -> ('unet', {width}); 'unet:W:E' -> ('unet', {width, extra_inputs}) (E = 0 gives
    {width} alone); 'fcn:H:C' -> ('fcn', {hidden, inputs, outputs})."""
    parts = spec.split(":")
    try:
        if parts[0] == "unet" and len(parts) in (2, 3):
            w = int(parts[1])
            e = int(parts[2]) if len(parts) == 3 else 0
            if w >= 1 and e >= 0:
                return "unet", {"width": w, **({"extra_inputs": e} if e else {})}
        elif parts[0] == "fcn" and len(parts) == 3:
            h, c = int(parts[1]), int(parts[2])
            if h >= 2 and c >= 1:
                return "fcn", {"hidden": h, "inputs": c, "outputs": FCN_OUTPUTS}
    except ValueError:
        pass
    raise ValueError(f"--arch {spec!r}, expected unet:W[:E] (W >= 1, E >= 0 extra inputs) or fcn:H:C (hidden H >= 2, C >= 1 inputs)")


def build_model(arch: str, dims: Dict[str, int], seed: int) -> nn.Module:
    """The randomized float32 model."""
    if arch == "unet":
        return randomize(UNet(dims["width"], dims.get("extra_inputs", 0)), seed)
    return randomize_fcn(FCN(dims["inputs"], dims["hidden"], dims["outputs"]), seed)


def io_shapes(arch: str, dims: Dict[str, int], batch: int) -> Tuple[List[int], List[int]]:
    if arch == "unet":
        return [batch, 2 + dims.get("extra_inputs", 0), 5, 5], [batch, 1, 5, 5]
    return [batch, dims["inputs"]], [batch, dims["outputs"]]


def uniform_f32(shape: List[int], seed: int, bound: float) -> torch.Tensor:
    """U(-bound, bound) drawn in float64 from a generator seeded `seed`, rounded to float32."""
    g = torch.Generator().manual_seed(seed)
    return (torch.rand(shape, generator=g, dtype=torch.float64) * (2 * bound) - bound).float()


def bn_names(model: nn.Module) -> List[str]:
    return [n for n, m in model.named_modules() if isinstance(m, nn.modules.batchnorm._BatchNorm)]


def training_step(model: nn.Module, x: torch.Tensor, y: torch.Tensor) -> Dict[str, torch.Tensor]:
    """One train-mode step on `model` (modified in place); returns the reference tensors (model dtype)."""
    model.train()
    for m in model.modules():
        if isinstance(m, nn.modules.batchnorm._BatchNorm):
            assert m.momentum == BN_MOMENTUM and m.eps == BN_EPS and m.track_running_stats
    params = dict(model.named_parameters())
    model.zero_grad(set_to_none=True)
    out = model(x)
    loss = torch.nn.functional.mse_loss(out, y)
    loss.backward()
    res: Dict[str, torch.Tensor] = {"output": out.detach().clone(), "loss": loss.detach().reshape(1).clone()}
    for name, p in params.items():
        res[f"grad.{name}"] = p.grad.detach().clone()
    for bn in bn_names(model):
        m = model.get_submodule(bn)
        res[f"after.{bn}.running_mean"] = m.running_mean.detach().clone()
        res[f"after.{bn}.running_var"] = m.running_var.detach().clone()
    opt = torch.optim.Adam(
        params.values(), lr=ADAM["lr"], betas=(ADAM["beta1"], ADAM["beta2"]), eps=ADAM["eps"],
        weight_decay=ADAM["weight_decay"], amsgrad=False, foreach=False,
    )
    opt.step()
    for name, p in params.items():
        res[f"adam.{name}"] = p.detach().clone()
    return res


def make(arch: str, dims: Dict[str, int], batch: int, seed: int) -> Tuple[Dict[str, torch.Tensor], Dict[str, str]]:
    """(tensors, metadata) of the fixture."""
    if arch == "unet" and batch < 2:
        raise ValueError("--batch must be >= 2 for the U-Net (BatchNorm at 1x1 needs more than one value per channel)")
    if batch < 1:
        raise ValueError("--batch must be >= 1")
    model32 = build_model(arch, dims, seed)
    start = {k: v.detach().clone() for k, v in model32.state_dict().items() if not k.endswith("num_batches_tracked")}
    assert all(v.dtype == torch.float32 for v in start.values())
    in_shape, out_shape = io_shapes(arch, dims, batch)
    x = uniform_f32(in_shape, seed + INPUT_SEED_OFFSET, INPUT_RANGE)
    y = uniform_f32(out_shape, seed + TARGET_SEED_OFFSET, TARGET_RANGE)

    ref = training_step(copy.deepcopy(model32).double(), x.double(), y.double())
    f32 = training_step(copy.deepcopy(model32), x, y)

    tensors: Dict[str, torch.Tensor] = {"input": x, "target": y}
    tensors.update({f"param.{k}": v for k, v in start.items()})
    tensors.update(ref)
    assert all(v.dtype == torch.float64 for k, v in ref.items())
    for k, v in tensors.items():
        if not torch.isfinite(v).all():
            raise RuntimeError(f"tensor {k} has non-finite values")

    # Parameters whose exact gradient is 0 (conv biases in front of a train-mode BN): their float64
    # gradient is round-off, and an F32 Adam step on F32 round-off can move them by up to ~lr.
    zero_grad = sorted(k[5:] for k, v in ref.items() if k.startswith("grad.") and float(v.abs().max()) < ZERO_GRAD)
    diffs: Dict[str, float] = {}
    for k, v in ref.items():
        g = k.split(".")[0]
        if g == "adam" and k[5:] in zero_grad:
            g = "adam_zero_grad_params"
        diffs[g] = max(diffs.get(g, 0.0), float((f32[k].double() - v).abs().max()))

    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "arch": arch,
        **{k: str(v) for k, v in dims.items()},
        "batch": str(batch),
        "seed": str(seed),
        "input_seed": str(seed + INPUT_SEED_OFFSET),
        "target_seed": str(seed + TARGET_SEED_OFFSET),
        "input_range": f"[{-INPUT_RANGE}, {INPUT_RANGE}]",
        "target_range": f"[{-TARGET_RANGE}, {TARGET_RANGE}]",
        "mode": "train",
        "compute_dtype": "float64",
        "loss": "torch.nn.functional.mse_loss(output, target): mean over all elements of (output - target)^2",
        "optimizer": json.dumps({"name": "adam", **ADAM, "amsgrad": False, "steps": 1}),
        "bn_momentum": repr(BN_MOMENTUM),
        "bn_eps": "1e-05",
        "bn_running_var": "unbiased batch variance (n / (n - 1)); normalisation uses the biased one",
        "torch_version": torch.__version__,
        "zero_grad_params": json.dumps(zero_grad),
        "torch_f32_max_abs_diff": json.dumps(diffs),
    }
    return tensors, meta


def main(argv: List[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--arch", required=True, help="unet:W[:E] or fcn:H:C")
    ap.add_argument("--batch", type=int, required=True)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    try:
        arch, dims = parse_arch(args.arch)
        tensors, meta = make(arch, dims, args.batch, args.seed)
    except ValueError as e:
        ap.error(str(e))
    safetensors_io.save(args.out, tensors, meta)
    n_params = sum(v.numel() for k, v in tensors.items() if k.startswith("grad."))
    print(
        f"wrote {args.out} ({args.out.stat().st_size} bytes): {args.arch}, batch {args.batch}, seed {args.seed}, "
        f"{n_params} learnable numbers, loss {float(tensors['loss'][0]):.10g}; "
        f"torch F32 vs F64 max |diff| {meta['torch_f32_max_abs_diff']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
