#!/usr/bin/env python3
"""Times PyTorch (CPU) training steps of the U-Net or the FCN baseline: the peer of glovepose's trainer.

Usage: /usr/bin/python3 bench/peers/torch_train_bench.py [--arch unet:64 | --arch fcn:H:C] [--batch 1024]
           [--threads 2] [--blas-threads N] [--reps 5] [--min-time 2] [--warmup 1] [--seed 1] [--foreach]
           [--no-profile]

    --arch unet:W     glovepose_ref.UNet(W), randomize(seed); input [B, 2, 5, 5], target [B, 1, 5, 5]
    --arch fcn:H:C    glovepose_ref.FCN(C, H, 25), randomize_fcn(seed); input [B, C], target [B, 25]

One step = model in train mode, optimizer.zero_grad(set_to_none=True), forward, loss =
torch.nn.functional.mse_loss(output, target), loss.backward(), one torch.optim.Adam step with the
paper's settings (lr 2e-4, betas (0.5, 0.999), eps 1e-8; PyTorch 1.13's default single-tensor
implementation unless --foreach). Input U(-1.2, 1.2) and target U(-1, 1), float32, drawn once from
seeded generators and reused by every step (the data pipeline is not timed).

Threads: OMP_NUM_THREADS and MKL_NUM_THREADS are set to --threads and OPENBLAS_NUM_THREADS to
--blas-threads (default: --threads) before torch is imported (Debian's torch runs Linear layers and
its im2col-based transposed convolutions on the system BLAS, OpenBLAS when installed, whose pool
torch.set_num_threads does not control), and torch.set_num_threads(threads).

Timing as bench/peers/torch_bench.py: warm-up for --warmup s, then --reps repetitions, each timing a
block of n steps (n chosen so a block lasts about --min-time s); reported is the median over
repetitions of the block mean step time, and samples/s = batch / that time. Unless --no-profile, one
extra step runs under torch.profiler first to list the convolution / matrix kernels PyTorch picked
(e.g. aten::mkldnn_convolution vs aten::slow_conv_transpose2d) with their self CPU time in ms.
The JSON also gives `others_cpu_share`: the share of all CPUs that other processes used during the
timed repetitions (from /proc/stat and this process's CPU time); above 0.05 a warning goes to stderr,
since the timings then shared the machine. Prints one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Callable, Dict, List, Tuple

ROOT = Path(__file__).resolve().parents[2]
ADAM = {"lr": 2e-4, "betas": (0.5, 0.999), "eps": 1e-8, "weight_decay": 0.0}
FCN_OUTPUTS = 25


def parse_args(argv: List[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--arch", default="unet:64", help="unet:W or fcn:H:C (default unet:64)")
    ap.add_argument("--batch", type=int, default=1024)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--blas-threads", type=int, default=None, help="OPENBLAS_NUM_THREADS (default: --threads)")
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--min-time", type=float, default=2.0)
    ap.add_argument("--warmup", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--foreach", action="store_true", help="Adam's multi-tensor (foreach) implementation")
    ap.add_argument("--no-profile", action="store_true")
    args = ap.parse_args(argv)
    if args.blas_threads is None:
        args.blas_threads = args.threads
    if args.threads < 1 or args.blas_threads < 1 or args.batch < 1 or args.reps < 1:
        ap.error("--threads, --blas-threads, --batch and --reps must be >= 1")
    parts = args.arch.split(":")
    ok = (parts[0] == "unet" and len(parts) == 2) or (parts[0] == "fcn" and len(parts) == 3)
    try:
        dims = [int(p) for p in parts[1:]]
    except ValueError:
        ok = False
    if not ok or min(dims) < 1:
        ap.error(f"--arch {args.arch!r}, expected unet:W or fcn:H:C")
    if parts[0] == "unet" and args.batch < 2:
        ap.error("--batch must be >= 2 for the U-Net (train-mode BatchNorm at 1x1)")
    args.kind, args.dims = parts[0], dims
    return args


def machine_busy_ticks() -> Tuple[int, int] | None:
    """(busy, total) jiffies of all CPUs from /proc/stat, or None where there is none."""
    try:
        f = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    except (OSError, ValueError):
        return None
    idle = f[3] + (f[4] if len(f) > 4 else 0)
    total = sum(f[:8])
    return total - idle, total


def time_steps(step: Callable[[object], object], x: object, reps: int, min_time: float,
               warmup: float) -> Tuple[List[float], int]:
    """(block mean step times in s, steps per block), the loop of torch_bench.time_case."""
    n = 0
    t0 = time.perf_counter()
    while True:
        step(x)
        n += 1
        if time.perf_counter() - t0 >= warmup:
            break
    per_run = (time.perf_counter() - t0) / n
    iters = max(1, round(min_time / per_run))
    means: List[float] = []
    for _ in range(reps):
        t = time.perf_counter()
        for _ in range(iters):
            step(x)
        means.append((time.perf_counter() - t) / iters)
    return means, iters


def main(argv: List[str] | None = None) -> int:
    args = parse_args(argv)
    os.environ["OMP_NUM_THREADS"] = os.environ["MKL_NUM_THREADS"] = str(args.threads)
    os.environ["OPENBLAS_NUM_THREADS"] = str(args.blas_threads)
    sys.path.insert(0, str(ROOT / "tools" / "python"))

    import torch  # noqa: E402  (after the thread variables)

    from glovepose_ref import FCN, UNet, randomize, randomize_fcn  # noqa: E402

    torch.set_num_threads(args.threads)
    if args.kind == "unet":
        (width,) = args.dims
        model = randomize(UNet(width), args.seed)
        in_shape, out_shape = [args.batch, 2, 5, 5], [args.batch, 1, 5, 5]
        desc: Dict[str, int] = {"width": width}
    else:
        hidden, inputs = args.dims
        model = randomize_fcn(FCN(inputs, hidden, FCN_OUTPUTS), args.seed)
        in_shape, out_shape = [args.batch, inputs], [args.batch, FCN_OUTPUTS]
        desc = {"hidden": hidden, "inputs": inputs, "outputs": FCN_OUTPUTS}
    model.train()
    g = torch.Generator().manual_seed(args.seed + 1000003)
    x = torch.rand(in_shape, generator=g) * 2.4 - 1.2
    g = torch.Generator().manual_seed(args.seed + 2000003)
    target = torch.rand(out_shape, generator=g) * 2 - 1
    opt = torch.optim.Adam(model.parameters(), lr=ADAM["lr"], betas=ADAM["betas"], eps=ADAM["eps"],
                           weight_decay=ADAM["weight_decay"], foreach=True if args.foreach else None)

    def step(inp: torch.Tensor) -> torch.Tensor:
        opt.zero_grad(set_to_none=True)
        loss = torch.nn.functional.mse_loss(model(inp), target)
        loss.backward()
        opt.step()
        return loss

    kernels: Dict[str, int] = {}
    if not args.no_profile:
        from torch.profiler import ProfilerActivity, profile  # noqa: E402

        step(x)  # first step allocates Adam's state; profile a steady-state one
        with profile(activities=[ProfilerActivity.CPU]) as prof:
            step(x)
        interesting = ("conv", "mkldnn", "addmm", "mm", "bmm", "batch_norm", "linear")
        for ev in prof.key_averages():
            if any(s in ev.key for s in interesting) and ev.self_cpu_time_total > 0:
                kernels[ev.key] = {"calls": int(ev.count), "self_ms": round(ev.self_cpu_time_total / 1e3, 3)}

    stat0, self0 = machine_busy_ticks(), os.times()
    means, iters = time_steps(step, x, args.reps, args.min_time, args.warmup)
    stat1, self1 = machine_busy_ticks(), os.times()
    others = None
    if stat0 is not None and stat1 is not None:
        hz = os.sysconf("SC_CLK_TCK")
        busy, total = (stat1[0] - stat0[0]) / hz, (stat1[1] - stat0[1]) / hz
        ours = (self1.user + self1.system) - (self0.user + self0.system)
        others = max(0.0, (busy - ours) / total) if total > 0 else 0.0
        if others > 0.05:
            print(f"torch_train_bench: warning: other processes used {others:.0%} of the CPUs during the timings", file=sys.stderr)
    med = statistics.median(means)
    final_loss = float(step(x))
    r = {
        "batch": args.batch,
        "reps": args.reps,
        "iters_per_rep": iters,
        "median_s_per_step": med,
        "median_us_per_sample": med * 1e6 / args.batch,
        "samples_per_s": args.batch / med,
        "rep_means_s": means,
    }
    out = {
        "engine": "pytorch",
        "version": torch.__version__,
        "what": "train step: forward (train mode) + mse_loss + backward + Adam(lr 2e-4, betas 0.5/0.999)",
        "arch": args.kind,
        **desc,
        "learnable_parameters": sum(p.numel() for p in model.parameters()),
        "threads": args.threads,
        "blas_threads": args.blas_threads,
        "torch_num_threads": torch.get_num_threads(),
        "cpus": os.cpu_count(),
        "others_cpu_share": others,
        "adam_foreach": bool(args.foreach),
        "mkldnn_available": bool(torch.backends.mkldnn.is_available()),
        "kernels_per_step": kernels,
        "loss_after_timing": final_loss,
        "results": [r],
    }
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
