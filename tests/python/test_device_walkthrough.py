"""docs/own_glove.md's "A device that is not a glove" walk-through, run as written (its sh block, with
build/ pointing at this build and examples/ at the repository's), then checked against what is
computed here from the CSV files the example wrote:
- the linear map against a least-squares fit with numpy on the same frames: each channel demeaned
  over its last 10 s (300 frames at 30 Hz, a rolling mean from the session's first frame), the
  training frames' range (min-max of the running median over the description's 0.5 s, clamp
  +-1.5), trained on session 0, scored on session 1 within the model's joint limits (within 1%);
- demeaning against reading the channels as they are: at most 0.8x the error on the held-out session;
- each model's validation figure (its file's validation_error_deg) against `eval` on that session
  (within 1e-6 degrees);
- `predict --raw` on the live file against the truth of the same frames, scored here: equal to
  `eval`'s mean (within 1e-4 degrees);
- the C ABI (libglovepose_c through the Python package) on the same live readings: its cells
  equal the rolling demean computed here, rounded to float as a dataset stores cells (within 1e-6:
  an ulp of float at 4, the sums' order differs), its angles equal `predict --raw`'s (1e-6 rad).

Environment: GLOVEPOSE_BUILD_DIR (tools/glovepose, examples/example_device) and GLOVEPOSE_LIBRARY
(libglovepose_c; the C ABI part is skipped, and says so, when the build has no C library).
"""
import json
import math
import os
import re
import sys
import tempfile

import numpy as np

from readme_blocks import sh_commands
from runner import conclude
from test_own_glove import ROOT, calibrated, read_safetensors, run

RATE, WINDOW_S = 30.0, 10.0


def demeaned(x, window):
    """Each column less the mean of its last `window` rows (fewer at the start), as a rolling mean."""
    sums = np.cumsum(x, axis=0)
    before = np.vstack([np.zeros((window, x.shape[1])), sums[:-window]]) if len(x) > window else np.zeros_like(x)
    seen = np.minimum(np.arange(1, len(x) + 1), window)[:, None]
    return x - (sums - before[: len(x)]) / seen


def load_take(path):
    header = open(path).readline().strip().split(",")
    values = np.loadtxt(path, delimiter=",", skiprows=1)
    channels = [i for i, n in enumerate(header) if n.startswith("channel_")]
    dofs = [i for i, n in enumerate(header) if n != "timestamp" and not n.startswith("channel_")]
    return values[:, 0], values[:, channels], values[:, dofs] if dofs else None


def c_abi_check(work, live_t, live_cells, raw, failures):
    """The live readings through the C ABI: cells against the rolling demean, angles against predict --raw."""
    sys.path.insert(0, os.path.join(ROOT, "python"))
    import glovepose  # noqa: E402  (the Python package: ctypes over libglovepose_c)

    model = glovepose.PoseModel(os.path.join(work, "device_fcn.safetensors"))
    estimator = glovepose.Estimator(model)
    estimator.use_training_calibration()
    window = int(WINDOW_S * RATE)
    expected = demeaned(live_cells, window).astype(np.float32).astype(np.float64)
    worst_cells, worst_angles, poses = 0.0, 0.0, 0
    for i in range(len(live_t)):
        status = estimator.push_cells(live_cells[i], live_t[i])
        worst_cells = max(worst_cells, float(np.max(np.abs(estimator.cells() - expected[i]))))
        if status == glovepose.Status.SOLVED:
            worst_angles = max(worst_angles, float(np.max(np.abs(estimator.angles() - raw[poses]))))
            poses += 1
    print(f"C ABI: {poses} poses; cells within {worst_cells:.2e} of the rolling demean, angles within {worst_angles:.2e} rad of predict --raw")
    if poses != len(raw):
        failures.append(f"the C ABI made {poses} poses, predict --raw {len(raw)}")
    if worst_cells > 1e-6:
        failures.append(f"the C ABI's cells differ from the rolling demean by {worst_cells:.3g}")
    if worst_angles > 1e-6:
        failures.append(f"the C ABI's angles differ from predict --raw's by {worst_angles:.3g} rad")


def main():
    commands = sh_commands("## A device that is not a glove", "docs/own_glove.md")
    assert len(commands) == 6, commands
    failures = []
    with tempfile.TemporaryDirectory() as work:
        outputs = [run(command, work) for command in commands]
        for command in commands:
            print("ran:", command)
        imported, linear_out, _, eval_out, raw_out = outputs[1:]
        print(imported.strip())

        # The linear map: both windows' validation errors printed, the better one kept.
        windows = dict(re.findall(r"^demean (\d+) s: validation error ([0-9.]+) deg", linear_out, re.M))
        print(f"linear map, validation on session 1: as read {windows.get('0')} deg, demeaned over 10 s {windows.get('10')} deg")
        if set(windows) != {"0", "10"}:
            failures.append(f"train printed the windows {sorted(windows)}, expected 0 and 10")
        elif not float(windows["10"]) <= 0.8 * float(windows["0"]):
            failures.append(f"demeaning gave {windows['10']} deg against {windows['0']} as read: more than 0.8x")
        if "demean 10 s: validation error" not in linear_out or "(kept)" not in linear_out.split("demean 10 s")[1].splitlines()[0]:
            failures.append("train did not keep the 10 s window:\n" + linear_out)

        # The least-squares fit here, on the CSV takes as the example wrote them.
        _, cells0, angles0 = load_take(os.path.join(work, "device", "session0.csv"))
        _, cells1, angles1 = load_take(os.path.join(work, "device", "session1.csv"))
        window = int(WINDOW_S * RATE)
        x0, x1 = demeaned(cells0, window), demeaned(cells1, window)
        median_window = int(0.5 * RATE + 0.5)
        train_x = calibrated(x0, x0, median_window, 0.001)
        # The training range applied to session 1: min-max of session 0's running median.
        medians = np.median(np.lib.stride_tricks.sliding_window_view(x0, median_window, axis=0), axis=-1)
        lo, hi = medians.min(axis=0), medians.max(axis=0)
        test_x = np.clip(2.0 * (x1 - lo) / (hi - lo) - 1.0, -1.5, 1.5)
        w, *_ = np.linalg.lstsq(np.hstack([train_x, np.ones((len(train_x), 1))]), angles0, rcond=None)
        _, meta = read_safetensors(os.path.join(work, "device_linear.safetensors"))
        limits_lo, limits_hi = np.array(json.loads(meta["joint_limits_min"])), np.array(json.loads(meta["joint_limits_max"]))
        predicted = np.clip(np.hstack([test_x, np.ones((len(test_x), 1))]) @ w, limits_lo, limits_hi)
        reference = float(np.mean(np.abs(predicted - angles1)) * 180.0 / math.pi)

        def eval_json(model):
            out = run(f"build/tools/glovepose eval --model {model} --data device.safetensors --sessions 1 --json", work)
            return json.loads(out)

        linear = eval_json("device_linear.safetensors")
        print(f"least squares here: {reference:.4f} deg; glovepose's linear map {linear['mean_deg']:.4f} deg")
        if abs(linear["mean_deg"] - reference) > 0.01 * reference:
            failures.append(f"the linear map's {linear['mean_deg']:.4f} deg differs from the fit here ({reference:.4f}) by more than 1%")

        # Each model's validation figure is eval on the held-out session.
        for name in ("device_linear.safetensors", "device_fcn.safetensors"):
            _, meta = read_safetensors(os.path.join(work, name))
            print(f"{name}: validation on {meta['validation']}")
            if not meta["validation"].startswith("1 held-out run of 2") or "session 1" not in meta["validation"]:
                failures.append(f"{name}: train validated on {meta['validation']}, expected session 1 held out")
            held = eval_json(name)["mean_deg"]
            stored = float(meta["validation_error_deg"])
            print(f"{name}: validation error {stored:.6f} deg, eval on session 1 {held:.6f} deg")
            if abs(stored - held) > 1e-6:
                failures.append(f"{name}: validation error {stored} deg, eval on the same session {held} deg")
            if name == "device_fcn.safetensors" and '"demean_seconds": 10' not in meta["glove_description"]:
                failures.append("the FCN's glove description does not carry demean_seconds 10")
        fcn_mean = float(re.search(r"^all\s+([0-9.]+)", eval_out, re.M).group(1))

        # predict --raw on the live readings, scored here against session 1's labels.
        raw = np.loadtxt(raw_out.splitlines(), delimiter=",", skiprows=1, ndmin=2)  # a header of DoF names
        live_t, live_cells, _ = load_take(os.path.join(work, "device", "session1_live.csv"))
        if raw.shape != angles1.shape or not np.array_equal(live_cells, cells1):
            failures.append(f"predict --raw gave {raw.shape} angles for the {angles1.shape} of session 1, or the live file is not its readings")
        else:
            scored = float(np.mean(np.abs(raw - angles1)) * 180.0 / math.pi)
            exact = eval_json("device_fcn.safetensors")["mean_deg"]
            print(f"FCN on session 1: eval {fcn_mean} deg (text), predict --raw scored here {scored:.6f} deg, eval --json {exact:.6f} deg")
            if abs(scored - exact) > 1e-4:
                failures.append(f"predict --raw's angles score {scored} deg, eval's {exact} deg")
            if os.environ.get("GLOVEPOSE_LIBRARY"):
                c_abi_check(work, live_t, live_cells, raw, failures)
            else:
                print("C ABI: skipped, this build has no libglovepose_c (GLOVEPOSE_LIBRARY unset)")
    conclude(failures)


if __name__ == "__main__":
    main()
