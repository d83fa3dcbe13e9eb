#!/usr/bin/env python3
"""Times the U-Net forward in PyTorch (CPU) and writes the ONNX check file for ort_bench.js.

Usage: /usr/bin/python3 bench/peers/torch_bench.py --model FILE.safetensors [--batches 1,1024]
           [--threads 1] [--reps 10] [--min-time 0.2] [--warmup 0.3] [--write-check FILE.json]
           [--no-jit]

The model is loaded with glovepose_ref.import_model (eval mode). Two variants are timed:
  eager   the nn.Module under torch.inference_mode()
  jit     torch.jit.freeze(torch.jit.trace(model)) + torch.jit.optimize_for_inference (BN folded
          into the convolutions, as glovepose and ONNX Runtime do); skipped with --no-jit
torch.set_num_threads(threads). Each case: warm-up, then --reps repetitions, each timing a block of
n forwards (n chosen so a block lasts about --min-time s); reported is the median over repetitions
of the block mean, like Google Benchmark's `median` aggregate. Prints one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Callable, Dict, List

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "python"))

import torch  # noqa: E402

from glovepose_ref import import_model  # noqa: E402
from torch_train_bench import time_steps  # noqa: E402  (the same timing loop; imports no torch itself)


def deterministic_input(batch: int, seed: int = 0) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.rand(batch, 2, 5, 5, generator=g) * 2.4 - 1.2


def time_case(fn: Callable[[torch.Tensor], torch.Tensor], batch: int, reps: int, min_time: float, warmup: float) -> Dict:
    x = deterministic_input(batch)
    means, iters = time_steps(fn, x, reps, min_time, warmup)
    med = statistics.median(means)
    return {
        "batch": batch,
        "reps": reps,
        "iters_per_rep": iters,
        "median_s_per_run": med,
        "median_us_per_frame": med * 1e6 / batch,
        "frames_per_s": batch / med,
        "rep_means_s": means,
    }


def main(argv: List[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", type=Path, required=True)
    ap.add_argument("--batches", default="1,1024")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--reps", type=int, default=10)
    ap.add_argument("--min-time", type=float, default=0.2)
    ap.add_argument("--warmup", type=float, default=0.3)
    ap.add_argument("--write-check", type=Path, help="write input/output of a batch of 4 as JSON for ort_bench.js --check")
    ap.add_argument("--no-jit", action="store_true")
    args = ap.parse_args(argv)

    torch.set_num_threads(args.threads)
    model = import_model(args.model)
    batches = [int(b) for b in args.batches.split(",") if b]

    if args.write_check:
        x = deterministic_input(4, seed=1)
        with torch.inference_mode():
            y = model(x)
        args.write_check.write_text(json.dumps({"shape": list(x.shape), "input": x.flatten().tolist(), "output": y.flatten().tolist()}))

    variants: Dict[str, Callable[[torch.Tensor], torch.Tensor]] = {}

    def eager(x: torch.Tensor) -> torch.Tensor:
        with torch.inference_mode():
            return model(x)

    variants["eager"] = eager
    if not args.no_jit:
        with torch.no_grad():
            frozen = torch.jit.optimize_for_inference(torch.jit.freeze(torch.jit.trace(model, deterministic_input(1)).eval()))

        def jit(x: torch.Tensor) -> torch.Tensor:
            with torch.no_grad():
                return frozen(x)

        with torch.inference_mode():
            ref = model(deterministic_input(8, seed=2))
        diff = float((jit(deterministic_input(8, seed=2)) - ref).abs().max())
        if diff > 1e-4:
            raise SystemExit(f"torch_bench: frozen TorchScript differs from eager by {diff}")
        variants["jit"] = jit

    results = []
    for name, fn in variants.items():
        for b in batches:
            r = time_case(fn, b, args.reps, args.min_time, args.warmup)
            results.append({"variant": name, "threads": args.threads, **r})
    print(json.dumps({"engine": "pytorch", "version": torch.__version__, "threads": args.threads,
                      "width": model.width, "results": results}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
