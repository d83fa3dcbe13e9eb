#!/usr/bin/env python3
"""What any contact detector that reads the estimated thumb-to-fingertip distance can reach.

    tools/experiments/contact_floor.py DISTANCES.csv [--smooth N ...]

DISTANCES.csv is `glovepose eval ... --pinch-distances DISTANCES.csv`: per frame the true and the
predicted thumb-to-fingertip distances (mm) of the four pairs and the true pinch flag (hand/pinch.hpp's
15/18 mm rule on the true pose). A detector here says "contact" when the predicted distance, or its
mean over the last N frames of the recording (--smooth, the pose's recent history), is below a
threshold T; T is swept from 5 to 60 mm in 0.25 mm steps. Per pair and pooled, per-frame precision
and recall against the true flag are printed at the pinch rule's 15 mm, at the break-even point
(the T where min(precision, recall) is largest), and the best recall at precision >= 0.95 and the
best precision at recall >= 0.95. Any detector thresholding a monotone function of the distance
lies on this curve; "reachable" says whether one T gives both >= 0.95.
"""
import argparse
import csv
import sys

PAIRS = ("index", "middle", "ring", "pinky")
TARGET = 0.95


def read(path):
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows.append(r)
    if not rows:
        sys.exit(f"{path}: no frames")
    return rows


def smoothed(rows, pair, n):
    """Per frame the mean predicted distance over the last n frames of its recording."""
    out, window = [], []
    for r in rows:
        if r["run_start"] == "1":
            window = []
        window.append(float(r["pred_mm_" + pair]))
        if len(window) > n:
            window.pop(0)
        out.append(sum(window) / len(window))
    return out


def curve(scores, truth):
    """(T, precision, recall, tp, fp, fn) for each threshold T: detector = score < T."""
    order = sorted(range(len(scores)), key=lambda i: scores[i])
    positives = sum(truth)
    points, tp, fp, k = [], 0, 0, 0
    steps = [5.0 + 0.25 * i for i in range(int((60.0 - 5.0) / 0.25) + 1)]
    for t in steps:
        while k < len(order) and scores[order[k]] < t:
            tp += truth[order[k]]
            fp += 1 - truth[order[k]]
            k += 1
        p = tp / (tp + fp) if tp + fp else float("nan")
        r = tp / positives if positives else float("nan")
        points.append((t, p, r, tp, fp, positives - tp))
    return points


def summary(label, points):
    def fmt(pt):
        return f"T {pt[0]:5.2f} mm: P {pt[1]:.3f} R {pt[2]:.3f}" if pt else "none"

    at15 = next(pt for pt in points if pt[0] == 15.0)
    valid = [pt for pt in points if pt[1] == pt[1] and pt[2] == pt[2]]
    even = max(valid, key=lambda pt: min(pt[1], pt[2])) if valid else None
    hi_p = [pt for pt in valid if pt[1] >= TARGET]
    hi_r = [pt for pt in valid if pt[2] >= TARGET]
    best_r = max(hi_p, key=lambda pt: pt[2]) if hi_p else None
    best_p = max(hi_r, key=lambda pt: pt[1]) if hi_r else None
    reachable = any(pt[1] >= TARGET and pt[2] >= TARGET for pt in valid)
    print(f"  {label:7s} true frames {points[0][3] + points[0][5]:6d} | at 15 mm {fmt(at15)} | break-even {fmt(even)}"
          f" | best R at P>={TARGET}: {fmt(best_r)} | best P at R>={TARGET}: {fmt(best_p)} | both >= {TARGET}: {'yes' if reachable else 'NO'}")
    return reachable


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("distances", help="CSV of glovepose eval --pinch-distances")
    parser.add_argument("--smooth", type=int, nargs="*", default=[1, 5, 15], help="frames of the mean (1: the pose's own distance)")
    args = parser.parse_args()
    rows = read(args.distances)
    subjects = sorted({int(r["subject"]) for r in rows})
    print(f"{len(rows)} frames, subjects {subjects}")
    for n in args.smooth:
        print(f"detector: predicted distance{'' if n == 1 else f', mean of the last {n} frames'} < T")
        all_scores, all_truth = [], []
        for pair in PAIRS:
            scores = smoothed(rows, pair, n) if n > 1 else [float(r["pred_mm_" + pair]) for r in rows]
            truth = [int(r["true_on_" + pair]) for r in rows]
            summary(pair, curve(scores, truth))
            all_scores += scores
            all_truth += truth
        summary("all", curve(all_scores, all_truth))


if __name__ == "__main__":
    main()
