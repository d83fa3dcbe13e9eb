#!/usr/bin/env python3
"""Two measurements of a simulated world on its corpora (docs/simulator.md, "How alike the fitted
world's people are, and how linear its glove is"): how linear the cells are in the angles, and how
much of the per-person spread of errors after calibration each person effect carries.

A. How linear the world's cells are (``linearity``). Per person, glove 0, its sessions (with
   ``--sessions 3`` all of one donning): cells from the TRUE angles, fitted on two sessions and
   scored on the third (all three folds), R^2 pooled over the cells (1 - sum SSE / sum SST, SST
   about the held-out session's mean), for a linear map (angles + bias) and flexible maps: a
   degree-2 polynomial (angles, their squares and products) and random Fourier features (RFF,
   Gaussian kernel) with the linear terms, both ridge, the bandwidth and ridge chosen on the
   training sessions alone (one trains, the other validates). Cells are either on-the-fly
   calibrated per session exactly as the library does (20-frame running median of the session's
   calibration sequence, min-max -> [-1, 1], flat and noise-only cells -> 0, clamp +-1.5:
   ``sensor::OnTheFlyCalibrator``), or raw (pF). Also the inverse, angles from calibrated cells,
   linear vs the same flexible maps, mean absolute error in degrees against the truth (or the
   labels) on the held-out session. Every recording frame counts, collision outliers included
   (they are outliers of the labels; the cells and the truth are sound).

B. Per-person spread after calibration (``spread``). Column (4)'s proxy: a linear least-squares map
   (bias, ridge 1e-6, as ``sim/report.hpp``) from on-the-fly calibrated cells to the labels
   (``angles``), trained on nine subjects and scored on the tenth (all ten folds), glove 0,
   collision-outlier frames dropped (``train/samples.hpp``); a subject's error is the mean absolute
   error over its frames and the 25 DoFs in degrees (``train/metrics.hpp``), against the labels and
   against the truth (``true_angles``). Per world: mean, SD over subjects (ddof 1), worst subject,
   correlation with the paper's column (4) and the smallest hand's (subject 9) rank (1 = worst).
   The same for columns (1) and (2)'s proxies: a linear map of the same kind per person, trained on
   its sessions 0, 1 and scored on session 2 (one donning, as Table 1's (1)), or trained on 0-3 and
   scored on 4 (a fresh donning, as (2)).

Commands (one seed per comparison, the same for every world; G=build/tools/glovepose):

    # B: 5 sessions per person (the first 3 on one donning: 3 donnings, as the default corpus) x 1 min
    C="--seed 1 --subjects 10 --sessions 5 --minutes 1 --gloves 1 --calibration-seconds 30 --threads 1"
    P="--without loose_fit,size_coupling,skin,shortfall,independent,placement"
    $G simulate $C --out w_d5_full.safetensors
    $G simulate $C --without loose_fit --out w_d5_no_loose_fit.safetensors   # likewise shortfall, independent, placement
    $G simulate $C --set people.skin_spread=0 --out w_d5_skin_0.safetensors
    $G simulate $C --set wear.size_coupling=0 --out w_d5_size_coupling_0.safetensors
    $G simulate $C --set tracker.subject_bias_sd=0 --out w_d5_no_subject_bias.safetensors
    $G simulate $C $P --set people.skin_spread=0,wear.size_coupling=0 --out w_d5_person_all_zero.safetensors
    $G simulate $C $P --set people.skin_spread=0,wear.size_coupling=0,tracker.subject_bias_sd=0 --out w_d5_person_all_zero_no_bias.safetensors
    $G simulate $C $P --set people.skin_spread=0,wear.size_coupling=0.5 --out w_d5_only_size.safetensors
    $G simulate $C $P --set people.skin_spread=0.7,wear.size_coupling=0 --out w_d5_only_skin.safetensors
    nice -n 19 /usr/bin/python3 tools/experiments/world_measures.py spread w_d5_*.safetensors

    # A: 3 sessions x 2 min, all on one donning (held-out sessions differ in motion, not in fit)
    $G simulate --seed 1 --subjects 10 --sessions 3 --minutes 2 --gloves 1 --calibration-seconds 30 --threads 1 --out w_full.safetensors
    nice -n 19 /usr/bin/python3 tools/experiments/world_measures.py linearity w_full.safetensors   # cells vs true angles; inverse vs truth
    nice -n 19 /usr/bin/python3 tools/experiments/world_measures.py linearity w_full.safetensors --cells cal --inverse-target labels

(`--without skin` sets the skin spread back to the clean world's 0.35, not 0; `--without
size_coupling` sets the coupling to 1.) MEASURE_RFF_LENGTHS (default 4,8,16: kernel lengths in
units of a standardised angle or cell) sets the random Fourier features' bandwidth grid. numpy and
torch run on one thread. Reading, calibration and samples are train_torch.py's (with the library's
noise-only rule), so this needs Debian's python3-torch and python3-numpy (/usr/bin/python3).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core: set before numpy and torch load their BLAS

import numpy as np  # noqa: E402
import torch  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

from glovepose_ref import safetensors_io  # noqa: E402
from glovepose_ref.export import JOINT_LIMITS_MAX, JOINT_LIMITS_MIN  # noqa: E402
from glovepose_ref.glove import glove_settings  # noqa: E402
from glovepose_ref.whole_file import write_whole  # noqa: E402
from train_torch import make_samples  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from report import PAPER_TABLE1_SUBJECTS  # noqa: E402

torch.set_num_threads(1)
DEG = 180.0 / np.pi
NEEDED = ("cells", "angles", "true_angles", "subject", "glove", "session", "kind", "outlier")


def die(message: str) -> None:
    sys.exit(f"world_measures: {message}")


def write_json(path, value):
    """`value` as JSON at `path`, whole or not at all."""
    write_whole(path, json.dumps(value, indent=1))


# --------------------------------------------------------------------------------------------------
# Dataset files (weights_format.md, "Dataset files") and their runs, calibrated as the library does.


def read_dataset(path):
    """(tensors, metadata) of a simulated glovepose dataset; exits naming what is missing."""
    if not os.path.isfile(path):
        die(f"'{path}': no such file")
    try:
        data, meta = safetensors_io.load(path)
    except (safetensors_io.FormatError, OSError) as e:
        die(f"'{path}': not a readable dataset file: {e}")
    if meta.get("format") != "glovepose-dataset":
        die(f"'{path}' is not a glovepose dataset file (format {meta.get('format')!r})")
    missing = [k for k in NEEDED if k not in data]
    if missing:
        die(f"'{path}' lacks the tensor(s) {', '.join(missing)} (a simulated corpus has them: glovepose simulate)")
    return data, meta


def sessions(data, meta, glove=0, outliers=False, raw=False):
    """Glove `glove`'s recordings, one dict per (subject, session): cells on-the-fly calibrated by the
    run's own calibration sequence (`cal`; `raw`: also the uncalibrated pF), labels and truth."""
    settings = glove_settings(None, JOINT_LIMITS_MIN, JOINT_LIMITS_MAX)
    recording = (data["kind"] == 0) & (data["glove"] == glove)
    if not bool(recording.any()):
        die(f"the dataset has no recording frames of glove {glove}")
    out = []
    for subject in sorted(set(data["subject"][recording].tolist())):
        mine = data["subject"] == subject  # this subject's frames only: make_samples converts all it is given
        person = {k: v[mine] for k, v in data.items()}
        for session in sorted(set(person["session"][(person["kind"] == 0) & (person["glove"] == glove)].tolist())):
            def samples(calibration):
                s, _, _ = make_samples(person, meta, [subject], calibration, 0.0, settings, gloves=[glove], sessions=[session],
                                       truth=True, noise_only=True, outliers=outliers)
                return s
            cal = samples("onthefly")
            part = dict(subject=subject, session=session, cal=cal["inputs"].numpy().astype(np.float64),
                        labels=cal["angles"].numpy().astype(np.float64), truth=cal["true_angles"].numpy().astype(np.float64))
            if raw:
                part["raw"] = samples("none")["inputs"].numpy().astype(np.float64)
            out.append(part)
    return out


# --------------------------------------------------------------------------------------------------
# B: the per-person spread of column (4)'s linear proxy.


def with_bias(x):
    return np.hstack([x, np.ones((len(x), 1))])


def leave_one_subject_out(parts):
    """Per subject: (mean abs error vs labels, vs truth), degrees; the map trained on the others' labels."""
    subjects = sorted({p["subject"] for p in parts})
    xtx = {s: 0.0 for s in subjects}
    xty = {s: 0.0 for s in subjects}
    for p in parts:
        x = with_bias(p["cal"])
        xtx[p["subject"]] = xtx[p["subject"]] + x.T @ x
        xty[p["subject"]] = xty[p["subject"]] + x.T @ p["labels"]
    result = {}
    for held in subjects:
        a = sum(xtx[s] for s in subjects if s != held)
        b = sum(xty[s] for s in subjects if s != held)
        w = np.linalg.solve(a + 1e-6 * np.eye(len(a)), b)
        err_l = err_t = n = 0.0
        for p in parts:
            if p["subject"] != held:
                continue
            pred = with_bias(p["cal"]) @ w
            err_l += np.abs(pred - p["labels"]).sum()
            err_t += np.abs(pred - p["truth"]).sum()
            n += p["labels"].size
        result[held] = (err_l / n * DEG, err_t / n * DEG)
    return result


def personal(parts, train, test):
    """Per subject: (mean abs error vs labels, vs truth), degrees, of a linear map trained on the
    subject's own sessions `train` and scored on its session `test` (Table 1's (1): 0, 1 -> 2; (2):
    0-3 -> 4). Subjects without those sessions are left out."""
    result = {}
    for subject in sorted({p["subject"] for p in parts}):
        mine = {p["session"]: p for p in parts if p["subject"] == subject}
        if test not in mine or any(t not in mine for t in train):
            continue
        x = np.vstack([with_bias(mine[t]["cal"]) for t in train])
        y = np.vstack([mine[t]["labels"] for t in train])
        w = np.linalg.solve(x.T @ x + 1e-6 * np.eye(x.shape[1]), x.T @ y)
        pred = with_bias(mine[test]["cal"]) @ w
        result[subject] = (np.abs(pred - mine[test]["labels"]).mean() * DEG, np.abs(pred - mine[test]["truth"]).mean() * DEG)
    return result


# Table 1's columns the spread measures, with the proxy of each: name, the paper's key, the errors.
SPREAD_COLUMNS = [
    ("(4) generic, leave one subject out", "cal", leave_one_subject_out),
    ("(1) personal intra, sessions 0, 1 -> 2", "intra", lambda parts: personal(parts, [0, 1], 2)),
    ("(2) personal inter, sessions 0-3 -> 4", "inter", lambda parts: personal(parts, [0, 1, 2, 3], 4)),
]


def paper_column(column="cal"):
    """The paper's Table 1 column per subject (report.py's PAPER_TABLE1_SUBJECTS; default (4))."""
    return np.array([row[column] for row in PAPER_TABLE1_SUBJECTS])


def spread(args):
    absent = [p for p in args.datasets if not os.path.isfile(p)]
    if absent:
        die(f"no such file: {', '.join(absent)}")
    corpora = []
    for path in args.datasets:
        data, meta = read_dataset(path)
        corpora.append((path, meta, sessions(data, meta)))
    rows = {}
    for title, key, errors in SPREAD_COLUMNS:
        paper = paper_column(key)
        print(f"\n## {title}\n\npaper: mean {paper.mean():.2f}, SD {paper.std(ddof=1):.2f}, worst subject {int(paper.argmax())} ({paper.max():.1f})\n")
        print("| world | mean (labels) | SD | SD / paper | worst | r with paper | subject 9 rank | mean (truth) | SD (truth) | worst (truth) |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        tens = []  # per ten-subject corpus: SD / paper's, r, subject 9's rank, its and subject 5's excess over the mean
        for path, meta, parts in corpora:
            res = errors(parts)
            if len(res) < 3:
                print(f"| {os.path.basename(path)} | {len(res)} subject(s) with these sessions: at least 3 needed |")
                continue
            subj = sorted(res)
            lab = np.array([res[s][0] for s in subj])
            tru = np.array([res[s][1] for s in subj])
            name = os.path.basename(path).replace(".safetensors", "").removeprefix("w_")
            rows.setdefault(name, dict(world=meta.get("world"), without=meta.get("world_without", ""), set=meta.get("world_set", "")))
            rows[name][key] = dict(labels=lab.tolist(), truth=tru.tolist())
            ratio = r = rank = ""
            if len(lab) == len(paper):
                ratio = f"{lab.std(ddof=1) / paper.std(ddof=1):.2f}"
                r = f"{np.corrcoef(lab, paper)[0, 1]:+.2f}"
                rank = str(int((lab > lab[9]).sum()) + 1)  # 1 = worst
                tens.append((lab.std(ddof=1) / paper.std(ddof=1), np.corrcoef(lab, paper)[0, 1], int(rank), lab[9] - lab.mean(),
                             lab[5] - lab.mean()))
            print(f"| {name} | {lab.mean():.2f} | {lab.std(ddof=1):.2f} | {ratio} | {subj[int(lab.argmax())]} ({lab.max():.2f}) | {r} | {rank} | "
                  f"{tru.mean():.2f} | {tru.std(ddof=1):.2f} | {subj[int(tru.argmax())]} ({tru.max():.2f}) |", flush=True)
        if len(tens) > 1:  # one ten-person SD varies by a factor of two between seeds: say the mean over them
            t = np.array(tens)
            print(f"over the {len(tens)} ten-subject corpora: SD / paper mean {t[:, 0].mean():.2f} ({t[:, 0].min():.2f}-{t[:, 0].max():.2f}); "
                  f"r with paper mean {t[:, 1].mean():+.2f}; subject 9's rank {', '.join(str(int(k)) for k in t[:, 2])}, "
                  f"above the mean by {t[:, 3].mean():+.2f} (paper {paper[9] - paper.mean():+.2f}); "
                  f"subject 5 above the mean by {t[:, 4].mean():+.2f} (paper {paper[5] - paper.mean():+.2f})")
    if args.json:
        write_json(args.json, rows)


# --------------------------------------------------------------------------------------------------
# A: linearity.


class Features:
    """Maps inputs (standardised on the training frames) to regression features."""

    def __init__(self, kind, x_train, rng=None, length=1.0, count=0):
        self.kind, self.mu, self.sd = kind, x_train.mean(axis=0), x_train.std(axis=0) + 1e-9
        if kind == "rff":
            d = x_train.shape[1]
            self.w = rng.normal(0.0, 1.0 / length, size=(d, count))
            self.b = rng.uniform(0.0, 2 * np.pi, size=count)

    def __call__(self, x):
        z = (x - self.mu) / self.sd
        cols = [z, np.ones((len(z), 1))]
        if self.kind == "poly2":
            i, j = np.triu_indices(z.shape[1])
            cols.append(z[:, i] * z[:, j] / np.sqrt(2.0))
        elif self.kind == "rff":
            cols.append(np.sqrt(2.0) * np.cos(z @ self.w + self.b))
        return np.hstack(cols)


def ridge_path(f, y, lambdas):
    """Ridge weights for every lambda (one eigendecomposition); lambda relative to the mean diagonal."""
    g = f.T @ f
    c = f.T @ y
    vals, vecs = np.linalg.eigh(g)
    proj = vecs.T @ c
    scale = np.trace(g) / len(g)
    return [vecs @ (proj / (vals + lam * scale)[:, None]) for lam in lambdas]


def r2_pooled(pred, y):
    sst = ((y - y.mean(axis=0)) ** 2).sum(axis=0)
    sse = ((pred - y) ** 2).sum(axis=0)
    use = sst > 1e-12 * max(sst.max(), 1e-300)
    return 1.0 - sse[use].sum() / sst[use].sum()


def score(pred, y, target):
    return r2_pooled(pred, y) if target == "cells" else -np.abs(pred - y).mean() * DEG


def fit_flexible(kind, x_tr, y_tr, x_va, y_va, target, rng, features, rff_lengths):
    """Chooses (length, lambda) on (tr -> va); returns the chosen settings."""
    lambdas = [1e-4, 1e-3, 1e-2, 1e-1, 1.0]
    lengths = [None] if kind in ("linear", "poly2") else rff_lengths
    best = (-np.inf, None, None)
    for length in lengths:
        seed = int(rng.integers(1 << 31))
        feat = Features(kind, x_tr, np.random.default_rng(seed), length, features)
        f_tr, f_va = feat(x_tr), feat(x_va)
        for lam, w in zip(lambdas, ridge_path(f_tr, y_tr, lambdas)):
            s = score(f_va @ w, y_va, target)
            if s > best[0]:
                best = (s, (length, seed), lam)
    return best[1], best[2]


def cross_validate(person, inputs, target, kind, stride, features, rng, rff_lengths):
    """Held-out-session score of one model kind: pooled R^2 (target cells) or mean abs degrees (angles).

    The flexible map's bandwidth and ridge are chosen once per person on its first two sessions
    (the first trains, the second validates), then every session is held out in turn."""
    sess = sorted(person, key=lambda p: p["session"])
    key = "_cells" if target == "cells" else target
    if kind == "linear":
        length, lam = (None, 0), 1e-6
    else:
        length, lam = fit_flexible(kind, sess[0][inputs][::stride], sess[0][key][::stride], sess[1][inputs][::stride],
                                   sess[1][key][::stride], target, rng, features, rff_lengths)
    scores = []
    for k, test in enumerate(sess):
        train = [p for j, p in enumerate(sess) if j != k]
        x_tr = np.vstack([p[inputs][::stride] for p in train])
        y_tr = np.vstack([p[key][::stride] for p in train])
        feat = Features(kind, x_tr, np.random.default_rng(length[1]), length[0], features)
        w = ridge_path(feat(x_tr), y_tr, [lam])[0]
        s = score(feat(test[inputs]) @ w, test[key], target)
        scores.append(s if target == "cells" else -s)  # score is higher-better: minus the error in degrees
    return float(np.mean(scores)), (length[0], lam)


def linearity(args):
    data, meta = read_dataset(args.dataset)
    kinds = ["linear"] + args.flexible.split(",")
    if any(k not in ("rff", "poly2") for k in kinds[1:]):
        die(f"--flexible {args.flexible!r}, expected rff, poly2 or both, comma-separated")
    cell_kinds = args.cells.split(",")
    if any(c not in ("cal", "raw") for c in cell_kinds):
        die(f"--cells {args.cells!r}, expected cal, raw or cal,raw")
    if args.stride < 1 or args.features < 1:
        die("--stride and --features must be >= 1")
    try:
        lengths = [float(v) for v in os.environ.get("MEASURE_RFF_LENGTHS", "4,8,16").split(",")]
    except ValueError:
        lengths = []
    if not lengths or min(lengths) <= 0:
        die(f"MEASURE_RFF_LENGTHS={os.environ.get('MEASURE_RFF_LENGTHS')!r}, expected positive numbers, comma-separated")
    parts = sessions(data, meta, outliers=True, raw="raw" in cell_kinds)
    # The random features of each table and person come from their own stream: a run on some
    # subjects gives those subjects' figures of a run on all.
    def rng(stream, subject):
        return np.random.default_rng([args.seed, stream, subject])

    subjects = sorted({p["subject"] for p in parts})
    if args.subjects:
        try:
            wanted = [int(s) for s in args.subjects.split(",")]
        except ValueError:
            die(f"--subjects {args.subjects!r}, expected subject ids, comma-separated")
        absent = [s for s in wanted if s not in subjects]
        if absent:
            die(f"--subjects: {absent} not in the dataset's glove-0 recordings (subjects {subjects})")
        subjects = wanted
    for s in subjects:
        count = sum(p["subject"] == s for p in parts)
        if count < 2:
            die(f"subject {s} has {count} session(s) on glove 0; holding one out needs at least 2")
    names = " | ".join(kinds)
    print(f"# {args.dataset}: world {meta.get('world')} without [{meta.get('world_without', '')}] set [{meta.get('world_set', '')}]; "
          f"training stride {args.stride}, RFF features {args.features}; flexible = the best of {kinds[1:]} on the held-out sessions")
    results = {}
    for stream, cells in enumerate(cell_kinds):
        what = "on-the-fly calibrated per session" if cells == "cal" else "raw, pF"
        print(f"\n## cells ({what}) from the true angles: held-out-session R^2 pooled over the cells\n")
        print(f"| subject | {names} | flexible | share of the explainable variance the linear map misses | chosen (length, ridge) |")
        print("|---|" + "---:|" * (len(kinds) + 2) + "---|")
        table = []
        for s in subjects:
            person = [dict(p, _cells=p[cells]) for p in parts if p["subject"] == s]
            out = [cross_validate(person, "truth", "cells", k, args.stride, args.features, rng(stream, s), lengths) for k in kinds]
            r = [o[0] for o in out]
            flex = max(r[1:])
            table.append(r + [flex, (flex - r[0]) / flex])
            print(f"| {s} | " + " | ".join(f"{v:.4f}" for v in r) + f" | {flex:.4f} | {100 * (flex - r[0]) / flex:.1f}% | "
                  + ", ".join(f"{o[1]}" for o in out[1:]) + " |", flush=True)
        t = np.array(table)
        print("| mean | " + " | ".join(f"{v:.4f}" for v in t[:, :-1].mean(axis=0)) + f" | {100 * t[:, -1].mean():.1f}% | |")
        print(f"(share from the means: {100 * (t[:, -2].mean() - t[:, 0].mean()) / t[:, -2].mean():.1f}%)")
        results[f"cells_{cells}"] = t.tolist()
    if args.inverse:
        target = args.inverse_target
        print(f"\n## the angles ({'true' if target == 'truth' else 'labels'}) from the calibrated cells, trained and scored on them: "
              "held-out-session mean abs error (deg, 25 DoFs)\n")
        print(f"| subject | {names} | best flexible / linear | chosen (length, ridge) |")
        print("|---|" + "---:|" * (len(kinds) + 1) + "---|")
        table = []
        for s in subjects:
            person = [p for p in parts if p["subject"] == s]
            out = [cross_validate(person, "cal", target, k, args.stride, args.features, rng(2, s), lengths) for k in kinds]
            e = [o[0] for o in out]
            table.append(e + [min(e[1:]) / e[0]])
            print(f"| {s} | " + " | ".join(f"{v:.2f}" for v in e) + f" | {min(e[1:]) / e[0]:.3f} | " + ", ".join(f"{o[1]}" for o in out[1:]) + " |",
                  flush=True)
        t = np.array(table)
        print("| mean | " + " | ".join(f"{v:.2f}" for v in t[:, :-1].mean(axis=0)) + f" | {t[:, -1].mean():.3f} | |")
        results[f"angles_from_cells_{target}"] = t.tolist()
    if args.json:
        write_json(args.json, results)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    a = sub.add_parser("linearity", help="measurement A: cells against the true angles, linear vs flexible maps")
    a.add_argument("dataset")
    a.add_argument("--stride", type=int, default=3, help="training frames: every STRIDE-th (60 Hz frames repeat each other)")
    a.add_argument("--features", type=int, default=1500, help="random Fourier features")
    a.add_argument("--seed", type=int, default=1)
    a.add_argument("--subjects", help="comma-separated subject ids (default: all)")
    a.add_argument("--flexible", default="rff", help="flexible maps, comma-separated: rff, poly2")
    a.add_argument("--cells", default="cal,raw", help="cal (on-the-fly calibrated), raw, or both")
    a.add_argument("--inverse-target", default="truth", choices=["truth", "labels"], help="angles of the inverse direction")
    a.add_argument("--no-inverse", dest="inverse", action="store_false", help="skip the angles-from-cells direction")
    a.add_argument("--json")
    b = sub.add_parser("spread", help="measurement B: per-subject errors of linear maps: leave one subject out (4), personal (1) and (2)")
    b.add_argument("datasets", nargs="+")
    b.add_argument("--json")
    args = ap.parse_args()
    linearity(args) if args.what == "linearity" else spread(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
