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
lies on this curve; "reachable" says whether one T gives both >= 0.95. --margin N leaves out the
frames within N frames of a true pinch's start or end (the transitions): what remains is the held
pinch poses and the poses well apart, an easier test.
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


def kept_frames(rows, pair, margin):
    """Per frame whether it is more than `margin` frames from a change of the true flag in its recording."""
    n = len(rows)
    distance = [n] * n
    last = None
    for i, r in enumerate(rows):  # frames since the last change (a recording's start is not a change)
        if r["run_start"] == "1":
            last = None
        elif rows[i - 1]["true_on_" + pair] != r["true_on_" + pair]:
            last = i
        if last is not None:
            distance[i] = i - last
    nxt = None
    for i in range(n - 1, -1, -1):  # frames until the next change
        if i + 1 < n and rows[i + 1]["run_start"] == "0" and rows[i + 1]["true_on_" + pair] != rows[i]["true_on_" + pair]:
            nxt = i + 1
        if i + 1 < n and rows[i + 1]["run_start"] == "1":
            nxt = None
        if nxt is not None:
            distance[i] = min(distance[i], nxt - i)
    return [d > margin for d in distance]


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
    parser.add_argument("--margin", type=int, default=0, help="leave out frames within this many of a true pinch's start or end")
    args = parser.parse_args()
    rows = read(args.distances)
    subjects = sorted({int(r["subject"]) for r in rows})
    print(f"{len(rows)} frames, subjects {subjects}" + (f", frames within {args.margin} of a true pinch's start or end left out" if args.margin else ""))
    for n in args.smooth:
        print(f"detector: predicted distance{'' if n == 1 else f', mean of the last {n} frames'} < T")
        all_scores, all_truth = [], []
        for pair in PAIRS:
            scores = smoothed(rows, pair, n) if n > 1 else [float(r["pred_mm_" + pair]) for r in rows]
            truth = [int(r["true_on_" + pair]) for r in rows]
            if args.margin:
                keep = kept_frames(rows, pair, args.margin)
                scores = [x for x, k in zip(scores, keep) if k]
                truth = [x for x, k in zip(truth, keep) if k]
            summary(pair, curve(scores, truth))
            all_scores += scores
            all_truth += truth
        summary("all", curve(all_scores, all_truth))


if __name__ == "__main__":
    main()
