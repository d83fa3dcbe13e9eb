#!/usr/bin/env python3
"""What a torn trace costs the shipped model, and what a substitute for its floating cells gives
back (docs/results.md, "A torn trace"). The simulator tears a trace mid-session (``simulate
--tear``: the cells beyond the break float and leave every row, docs/simulator.md "Readout");
the library's full-M solve then reads them as about 0 pF. Per trace, the same people and frames:

- ``intact``: the glove as made;
- ``none``: torn, the cells as solved (the estimator with ``EstimatorConfig::floating_cells`` off);
- ``mid``: torn, each floating cell replaced by the middle of its range in the calibration frames;
- ``reg_cal``: torn, each floating cell predicted from the connected cells by a ridge regression
  fitted on the person's calibration frames (what the estimator holds before any session);
- ``reg_pre``: as ``reg_cal``, fitted on the calibration frames and the session's frames before
  the tear.

A cell counts as floating where it reads below a quarter of the least it read in the calibration
(found per person over the session: in more than half of its frames); the script reports how many
it found against the cells the tear floats (``simulate --tear`` knows them). Substitutes are
written into a copy of the dataset's cells, which ``glovepose eval --predictions`` scores; the
error is the mean absolute error over the 25 DoFs against the true angles, in degrees, over the
session frames from 1 s after the tear on, and each torn figure is given as a ratio to the intact
glove's on the same frames.

    G=build/tools/glovepose /usr/bin/python3 tools/experiments/torn_traces.py --seed 971 --subjects 4 --traces 0-26

Seed 971 was used by no model or choice (the shipped models are trained on seeds 1-300's people).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
CLI = os.environ.get("G", str(ROOT / "build" / "tools" / "glovepose"))
MODEL = str(ROOT / "models" / "glovepose_fcn512.safetensors")
MODES = ("none", "mid", "reg_cal", "reg_pre")


def read_tensors(path: Path):
    data = bytearray(path.read_bytes())
    size = struct.unpack("<Q", data[:8])[0]
    header = json.loads(data[8:8 + size])
    return data, header, 8 + size


def tensor(data, header, base, name, dtype):
    start, end = header[name]["data_offsets"]
    return np.frombuffer(bytes(data[base + start:base + end]), dtype=dtype).reshape(header[name]["shape"])


def substitute(src: Path, dst: Path, mode: str, tear_seconds: float, calibration_seconds: float) -> int:
    """Writes src's dataset with its floating cells replaced as `mode` says; returns the floating cells found."""
    data, header, base = read_tensors(src)
    cells = tensor(data, header, base, "cells", np.float32).astype(np.float64).copy()
    kind = tensor(data, header, base, "kind", np.uint8)
    subject = tensor(data, header, base, "subject", np.int32)
    time = tensor(data, header, base, "timestamps", np.float64)
    found = 0
    for s in np.unique(subject):
        rows = np.where(subject == s)[0]
        calibration, session = rows[kind[rows] == 1], rows[kind[rows] != 1]
        low, high = cells[calibration].min(0), cells[calibration].max(0)
        below = cells[session] < 0.25 * low
        floating = np.where(below.mean(0) > 0.5)[0]
        found += len(floating)
        if len(floating) == 0 or mode == "none":
            continue
        connected = np.setdiff1d(np.arange(cells.shape[1]), floating)
        hit = session[below[:, floating].any(1)]
        if mode == "mid":
            cells[np.ix_(hit, floating)] = (low[floating] + high[floating]) / 2
            continue
        before = session[time[session] < calibration_seconds + tear_seconds]
        fit = calibration if mode == "reg_cal" else np.concatenate([calibration, before])
        x = np.c_[cells[np.ix_(fit, connected)], np.ones(len(fit))]
        y = cells[np.ix_(fit, floating)]
        ridge = 1e-3 * np.trace(x.T @ x) / x.shape[1]
        weights = np.linalg.solve(x.T @ x + ridge * np.eye(x.shape[1]), x.T @ y)
        cells[np.ix_(hit, floating)] = np.c_[cells[np.ix_(hit, connected)], np.ones(len(hit))] @ weights
    start, end = header["cells"]["data_offsets"]
    data[base + start:base + end] = cells.astype(np.float32).tobytes()
    dst.write_bytes(bytes(data))
    return found


def frame_errors(path: Path, after: float):
    out = {}
    with open(path) as f:
        rows = csv.reader(f)
        head = next(rows)
        pred, truth = head.index("pred_thumb_base_abduction"), head.index("truth_thumb_base_abduction")
        for row in rows:
            if float(row[1]) >= after:
                out[(row[2], row[3], row[0])] = sum(abs(float(row[pred + k]) - float(row[truth + k])) for k in range(25)) / 25 * 180 / math.pi
    return out


def run(args: list) -> str:
    result = subprocess.run([CLI, *args], capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"glovepose {' '.join(args)} failed:\n{result.stderr}")
    return result.stdout + result.stderr


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=971)
    parser.add_argument("--subjects", type=int, default=4)
    parser.add_argument("--minutes", type=float, default=2.0)
    parser.add_argument("--traces", default="0-26", help="traces to tear, e.g. 0-26 or 4,19")
    parser.add_argument("--kept", type=int, default=1, help="cells each trace keeps, nearest the wrist")
    parser.add_argument("--tear-seconds", type=float, default=20.0)
    parser.add_argument("--threads", type=int, default=0)
    args = parser.parse_args()
    traces = []
    for part in args.traces.split(","):
        a, _, b = part.partition("-")
        traces += list(range(int(a), int(b or a) + 1))
    work = Path(tempfile.mkdtemp(prefix="glovepose_torn_"))
    common = ["--seed", str(args.seed), "--subjects", str(args.subjects), "--sessions", "1", "--gloves", "1", "--minutes", str(args.minutes),
              "--threads", str(args.threads)]
    calibration_seconds = 30.0  # simulate's default calibration before each session
    after = calibration_seconds + args.tear_seconds + 1.0
    run(["simulate", *common, "--out", str(work / "intact.safetensors")])
    run(["eval", "--model", MODEL, "--data", str(work / "intact.safetensors"), "--predictions", str(work / "intact.csv"), "--threads",
         str(args.threads)])
    intact = frame_errors(work / "intact.csv", after)
    base = sum(intact.values()) / len(intact)
    print(f"seed {args.seed}, {args.subjects} people, {args.minutes} min sessions, torn at {args.tear_seconds} s keeping {args.kept} cell(s);"
          f" intact glove {base:.3f} deg over {len(intact)} frames from 1 s after the tear")
    print("trace  floating found  " + "  ".join(f"{m:>8}" for m in MODES) + "   (found: floating cells found per person)")
    ratios = {m: [] for m in MODES}
    for trace in traces:
        torn = work / f"torn{trace}.safetensors"
        told = run(["simulate", *common, "--tear", str(trace), str(args.kept), str(args.tear_seconds), "--out", str(torn)])
        floats = told.split("float: cells ")[1].split(")")[0].split(", ") if "float: cells " in told else []
        row, found = [], 0
        for mode in MODES:
            fixed = work / f"{mode}.safetensors"
            found = substitute(torn, fixed, mode, args.tear_seconds, calibration_seconds)
            run(["eval", "--model", MODEL, "--data", str(fixed), "--predictions", str(work / f"{mode}.csv"), "--threads", str(args.threads)])
            errors = frame_errors(work / f"{mode}.csv", after)
            keys = intact.keys() & errors.keys()
            ratio = sum(errors[k] for k in keys) / sum(intact[k] for k in keys)
            ratios[mode].append(ratio)
            row.append(ratio)
        print(f"{trace:5d}  {len(floats):8d} {found // args.subjects:5d}  " + "  ".join(f"{r:8.3f}" for r in row), flush=True)
    print("mean                   " + "  ".join(f"{np.mean(ratios[m]):8.3f}" for m in MODES))
    print("worst                  " + "  ".join(f"{np.max(ratios[m]):8.3f}" for m in MODES))
    return 0


if __name__ == "__main__":
    sys.exit(main())
