#!/usr/bin/env python3
"""Writes a random U-Net and a reference input/output pair for the C++ numerics tests.

Usage: /usr/bin/python3 tools/python/make_fixtures.py --width W --seed S --batch B [--extra E] \
           --out-model MODEL --out-io IO

The fixtures in tests/fixtures were made with
    /usr/bin/python3 tools/python/make_fixtures.py --width 4 --seed 1 --batch 16 \
        --out-model tests/fixtures/unet_w4.safetensors --out-io tests/fixtures/unet_w4_io.safetensors
    /usr/bin/python3 tools/python/make_fixtures.py --width 4 --seed 5 --batch 8 --extra 2 \
        --out-model tests/fixtures/unet_w4_e2.safetensors --out-io tests/fixtures/unet_w4_e2_io.safetensors

The model file is glovepose_ref.export_model of randomize(UNet(width, E), seed) in eval mode (F32).
With --extra E > 0 (a U-Net for a glove with E extra inputs, default 0) the model file carries a
glove description (metadata glove_description, glove id "fixture-e<E>"): the built-in glove's 44
cells followed by E extra inputs "extra0".."extra<E-1>", so enc1.weight is [W, 2 + E, 5, 5] and the
file states the glove it belongs to. E = 0 writes the built-in glove's file as before.
The I/O file (same container, metadata format=glovepose-unet-io) holds
    input   [batch, 2 + E, 5, 5] F32, uniform in [-1.2, 1.2] (the calibrated range [-1, 1] plus
            margin), every value drawn independently (the extra planes are NOT constant: the
            network's numerics are checked on any input; a glove's frames give constant ones)
    output  [batch, 1, 5, 5] F32, the model's output computed in float64 (on a float64 copy of the
            F32 weights and input) and rounded once to float32,
so the reference differs from the exact result by F32 rounding only.
The input is drawn from its own generator seeded with seed + 1000003. Its metadata: width, seed,
batch, extra_inputs (only when E > 0), input_range, reference, max_abs_diff_torch_f32.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import torch  # noqa: E402

from glovepose_ref import UNet, export_model, import_model, randomize, safetensors_io  # noqa: E402
from glovepose_ref.glove import BUILTIN_DOF_SLOTS, DOF_NAMES, builtin_cell_slots  # noqa: E402

INPUT_SEED_OFFSET = 1000003
INPUT_RANGE = 1.2


def fixture_glove(extra: int) -> dict:
    """The glove description of an --extra fixture: the built-in glove's 44 cells on their slots,
    then `extra` extra inputs, and the built-in pose-map slots."""
    cells = [{"name": f"cell_{i}", "channel": ch, "row": r, "col": c} for i, (ch, r, c) in enumerate(builtin_cell_slots())]
    cells += [{"name": f"extra{k}", "extra": True} for k in range(extra)]
    dofs = [{"name": n, "row": r, "col": c} for n, (r, c) in zip(DOF_NAMES, BUILTIN_DOF_SLOTS)]
    return {"format": "glovepose-glove", "version": 1, "id": f"fixture-e{extra}", "cells": cells, "dofs": dofs}


def reference_io(model: UNet, seed: int, batch: int) -> tuple[torch.Tensor, torch.Tensor]:
    """(input F32 [batch, 2 + model.extra_inputs, 5, 5], output F32) with the output computed in
    float64 from the F32 weights and input."""
    g = torch.Generator().manual_seed(seed + INPUT_SEED_OFFSET)
    planes = 2 + model.extra_inputs
    x = (torch.rand(batch, planes, 5, 5, generator=g, dtype=torch.float64) * (2 * INPUT_RANGE) - INPUT_RANGE).float()
    m64 = copy.deepcopy(model).eval().double()
    with torch.no_grad():
        y = m64(x.double()).float()
    return x, y


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--batch", type=int, required=True)
    ap.add_argument("--extra", type=int, default=0, help="extra inputs E of the glove (input planes 2 + E; default 0)")
    ap.add_argument("--out-model", type=Path, required=True)
    ap.add_argument("--out-io", type=Path, required=True)
    args = ap.parse_args(argv)
    if args.extra < 0:
        ap.error(f"--extra {args.extra}, expected >= 0")

    model = randomize(UNet(args.width, args.extra), args.seed).eval()
    if args.extra:
        glove = fixture_glove(args.extra)
        export_model(model, args.out_model, glove=glove["id"], glove_description=json.dumps(glove))
    else:
        export_model(model, args.out_model)
    # Take the reference from the model as the file stores it, so the fixture pair is consistent by
    # construction (F32 storage is exact, this only guards against future changes).
    stored = import_model(args.out_model)
    x, y = reference_io(stored, args.seed, args.batch)
    with torch.no_grad():
        y32 = stored(x)
    meta = {
        "format": "glovepose-unet-io",
        "width": str(args.width),
        "seed": str(args.seed),
        "batch": str(args.batch),
        **({"extra_inputs": str(args.extra)} if args.extra else {}),
        "input_range": f"[{-INPUT_RANGE}, {INPUT_RANGE}]",
        "reference": "float64 forward of the F32 weights and input, rounded to F32",
        "max_abs_diff_torch_f32": repr(float((y32 - y).abs().max())),
    }
    safetensors_io.save(args.out_io, {"input": x, "output": y}, meta)
    print(
        f"wrote {args.out_model} (width {args.width}, seed {args.seed}, extra inputs {args.extra}) and {args.out_io} "
        f"(batch {args.batch}); output range [{float(y.min()):.4f}, {float(y.max()):.4f}], "
        f"torch F32 vs reference max |diff| {meta['max_abs_diff_torch_f32']}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
