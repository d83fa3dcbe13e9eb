#!/usr/bin/env python3
"""Writes a randomly initialised U-Net as a glovepose model file (for tests and benchmarks).

Usage: /usr/bin/python3 tools/python/export.py --width 64 --seed 1 --out FILE [--dtype F32|F16|BF16]
       [--glove ID] [--onnx FILE.onnx]

Weights come from glovepose_ref.randomize(model, seed) (BN statistics included), so the same
width and seed always give the same file. --onnx also writes the same model as ONNX (batch axis
dynamic) for the peer benchmark in bench/peers.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import torch  # noqa: E402

from glovepose_ref import UNet, count_parameters, export_model, randomize  # noqa: E402
from glovepose_ref.onnx_export import export_onnx  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=int, default=64, help="U-Net base width (default 64)")
    ap.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    ap.add_argument("--out", type=Path, help="model file to write (.safetensors)")
    ap.add_argument("--dtype", default="F32", choices=["F32", "F16", "BF16"], help="stored dtype")
    ap.add_argument("--glove", default="glauser2019-44", help="glove id written to the metadata")
    ap.add_argument("--onnx", type=Path, help="also write the model as ONNX to this file")
    args = ap.parse_args(argv)
    if args.out is None and args.onnx is None:
        ap.error("give --out and/or --onnx")
    model = randomize(UNet(args.width), args.seed).eval()
    if args.out is not None:
        export_model(model, args.out, glove=args.glove, dtype=args.dtype)
        print(f"wrote {args.out}: width {args.width}, seed {args.seed}, {count_parameters(model)['learnable']:,} parameters, {args.dtype}")
    if args.onnx is not None:
        export_onnx(model, args.onnx)
        print(f"wrote {args.onnx}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
