#!/usr/bin/env python3
"""What a per-joint confidence can know before it is built (issue: a confidence for every joint).
Two seeds of new people follow the default product path (the guided calibration, one 2-minute
session each), and the shipped model's per-frame angles are scored against the true angles
(``glovepose eval --predictions``). The first seed gives each DoF's mean error (a prior the
model file could carry); on the second seed, every joint-frame's error is ranked by a candidate
signal and the quarter with the highest expected error is compared with the quarter with the
lowest, as the issue's acceptance figure does:

- ``prior``: the DoF's mean error on the first seed (the same for every frame of a DoF);
- ``speed``: how fast the predicted angle moves (mean |d angle/dt| over the 10 frames up to this
  one: what the estimator knows at the frame; the readout's mean window and the network lag
  behind a moving hand), ranked within each person and DoF;
- ``offcentre``: how far the predicted angle lies from the person's mean for the DoF, ranked
  within each person and DoF.

The prior alone ranks joints across DoFs; the within-DoF rankings say how much a per-frame
signal adds. Seeds 981 and 982 were used by no model or choice.

    G=build/tools/glovepose /usr/bin/python3 tools/experiments/confidence_signals.py --seeds 981,982 --subjects 4
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

DOFS = 25


def run(cmd: list[str]) -> None:
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"confidence_signals: '{' '.join(cmd)}' failed: {done.stderr.strip()}")


def predictions(g: str, model: str, seed: int, subjects: int, work: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Predicted and true angles (radians), subject and time of every session frame of one seed."""
    sequence = os.path.join(work, "sequence.json")
    if not os.path.exists(sequence):
        with open(sequence, "w") as out:
            done = subprocess.run([g, "simulate", "--print-calibration-sequence"], stdout=out, stderr=subprocess.PIPE, text=True)
        if done.returncode != 0:
            sys.exit(f"confidence_signals: the calibration sequence: {done.stderr.strip()}")
    data = os.path.join(work, f"s{seed}.safetensors")
    csv = os.path.join(work, f"p{seed}.csv")
    run([g, "simulate", "--seed", str(seed), "--subjects", str(subjects), "--sessions", "1", "--gloves", "1", "--minutes", "2",
         "--calibration-sequence", sequence, "--threads", "0", "--out", data])
    run([g, "eval", "--model", model, "--data", data, "--sessions", "0", "--predictions", csv, "--threads", "0"])
    with open(csv) as f:
        header = f.readline().strip().split(",")
    table = np.genfromtxt(csv, delimiter=",", skip_header=1)
    pred = [i for i, name in enumerate(header) if name.startswith("pred_")]
    truth = [i for i, name in enumerate(header) if name.startswith("truth_")]
    if len(pred) != DOFS or len(truth) != DOFS or len(table) == 0:
        sys.exit(f"confidence_signals: {csv}: expected {DOFS} pred_ and truth_ columns and frames")
    return table[:, pred], table[:, truth], table[:, header.index("subject")], table[:, header.index("time")]


def quarter_ratio(expected: np.ndarray, error: np.ndarray) -> float:
    """Mean error of the quarter with the highest `expected` over the quarter with the lowest."""
    order = np.argsort(expected, kind="stable")
    q = len(order) // 4
    return float(error[order[-q:]].mean() / error[order[:q]].mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="981,982", help="the prior's seed and the scored seed")
    parser.add_argument("--subjects", type=int, default=4)
    parser.add_argument("--model", default="models/glovepose_fcn512.safetensors")
    args = parser.parse_args()
    g = os.environ.get("G", "build/tools/glovepose")
    seeds = [int(s) for s in args.seeds.split(",")]
    if len(seeds) != 2:
        sys.exit("confidence_signals: --seeds: expected two seeds, the prior's and the scored one")
    with tempfile.TemporaryDirectory() as work:
        p0, t0, _, _ = predictions(g, args.model, seeds[0], args.subjects, work)
        p1, t1, subject, time = predictions(g, args.model, seeds[1], args.subjects, work)
    prior = np.degrees(np.abs(p0 - t0)).mean(0)
    error = np.degrees(np.abs(p1 - t1))
    print(f"per-DoF mean error, seed {seeds[0]} (deg): " + " ".join(f"{e:.1f}" for e in prior))
    print(f"per-DoF mean error, seed {seeds[1]} (deg): " + " ".join(f"{e:.1f}" for e in error.mean(0)))
    print(f"rank correlation of the two: {np.corrcoef(np.argsort(np.argsort(prior)), np.argsort(np.argsort(error.mean(0))))[0, 1]:.2f}")
    print(f"prior: {quarter_ratio(np.broadcast_to(prior, error.shape).ravel(), error.ravel()):.2f}x "
          f"(all {error.size} joint-frames of seed {seeds[1]})")
    speed = np.zeros_like(p1)
    offcentre = np.zeros_like(p1)
    for s in np.unique(subject):  # each person's stream alone
        rows = np.flatnonzero(subject == s)
        rate = np.zeros((len(rows), DOFS))
        rate[1:] = np.abs(np.diff(p1[rows], axis=0)) / np.maximum(np.diff(time[rows])[:, None], 1e-3)
        running = np.cumsum(rate, axis=0)
        trailing = running - np.vstack([np.zeros((10, DOFS)), running[:-10]])[: len(rows)]  # the last 10 frames' sum
        speed[rows] = trailing / np.minimum(np.arange(1, len(rows) + 1), 10)[:, None]
        offcentre[rows] = np.abs(p1[rows] - p1[rows].mean(0))
    for name, signal in (("speed", speed), ("offcentre", offcentre)):
        ratios = [quarter_ratio(signal[subject == s, d], error[subject == s, d]) for s in np.unique(subject) for d in range(DOFS)]
        print(f"{name}: {np.median(ratios):.2f}x median over {len(ratios)} (person, DoF) pairs (range {min(ratios):.2f}-{max(ratios):.2f})")


if __name__ == "__main__":
    main()
