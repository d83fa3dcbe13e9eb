"""The README's "Your own glove" walk-through, run as written (its sh block, with build/ pointing at
this build), then checked against a linear least-squares fit computed here with numpy from the
imported dataset: the same on-the-fly calibration as the glove description asks for (min-max of
the running median over its calibration.median_seconds at its rate_hz, a third of a second by
default; sensors flat by its calibration.flat_relative_range to 0; clamp +-1.5), the same training frames (subjects 0-2 less the held-out runs that validate),
the error on subject 3 over the 21 labelled DoFs, the angles kept within the joint limits.
glovepose's linear map must agree within 1%
(it adds a ridge of 1e-6 relative and works in float), and the U-Net must not be worse than
1.1x the least-squares fit.

Environment: GLOVEPOSE_BUILD_DIR (the build tree: tools/glovepose, examples/example_glove).
"""
import contextlib
import json
import math
import os
import re
import shlex
import struct
import subprocess
import sys
import tempfile

import numpy as np

from readme_blocks import sh_commands
from runner import conclude

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
BUILD = os.environ["GLOVEPOSE_BUILD_DIR"]

DTYPES = {"F64": np.float64, "F32": np.float32, "I32": np.int32, "U8": np.uint8, "I64": np.int64}


def read_safetensors(path):
    with open(path, "rb") as f:
        size = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(size))
        data = f.read()
    meta = header.pop("__metadata__", {})
    tensors = {}
    for name, t in header.items():
        begin, end = t["data_offsets"]
        tensors[name] = np.frombuffer(data[begin:end], dtype=DTYPES[t["dtype"]]).reshape(t["shape"])
    return tensors, meta


def readme_commands():
    return sh_commands("## Your own glove")


def run(command, cwd):
    """One documented command as written (`build/` is this build, `examples/...` the repository's
    examples; `< FILE` feeds FILE to stdin); its stdout, or exit with its output when it fails."""
    args = shlex.split(command)
    if args[0].startswith("build/"):
        args[0] = os.path.join(BUILD, args[0][len("build/"):])
    args = [os.path.join(ROOT, a) if a.startswith("examples/") else a for a in args]
    feed = None
    if "<" in args:
        feed = os.path.join(cwd, args[args.index("<") + 1])
        args = args[: args.index("<")]
    with open(feed, "rb") if feed else contextlib.nullcontext() as stdin:
        result = subprocess.run(args, cwd=cwd, capture_output=True, text=True, stdin=stdin)
    if result.returncode != 0:
        sys.exit(f"FAIL: {command}\n{result.stdout}\n{result.stderr}")
    return result.stdout


def calibrated(cells, calibration, window, flat, clamp=1.5):
    medians = np.median(np.lib.stride_tricks.sliding_window_view(calibration.astype(np.float64), window, axis=0), axis=-1)
    lo, hi = medians.min(axis=0), medians.max(axis=0)
    span = hi - lo
    is_flat = (span <= flat * np.maximum(np.abs(lo), np.abs(hi))) | (span <= 0)
    out = np.clip(2.0 * (cells - lo) / np.where(is_flat, 1.0, span) - 1.0, -clamp, clamp)
    out[:, is_flat] = 0.0
    return out


def main():
    commands = readme_commands()
    assert len(commands) == 7, commands
    outputs = {}
    with tempfile.TemporaryDirectory() as work:
        for command in commands:
            outputs[command] = run(command, work)
            print("ran:", command)
        data, meta = read_safetensors(os.path.join(work, "mydata.safetensors"))
        description = json.load(open(os.path.join(work, "myglove", "example-20.json")))
        settings = description.get("calibration", {})
        rate = float(description["rate_hz"])
        assert float(meta["frame_rate"]) == rate, (meta["frame_rate"], rate)  # import took the description's rate
        window = max(1, math.floor(settings.get("median_seconds", 1.0 / 3.0) * rate + 0.5))
        flat = settings.get("flat_relative_range", 0.01)

        labelled = meta["labelled_dofs"].split(",")
        assert len(labelled) == 21, labelled
        dof_names = [n for n in re.findall(r'\{"([a-z_]+)"', open(os.path.join(ROOT, "include/glovepose/hand/dofs.hpp")).read())
                     if "_" in n][:25]
        columns = [dof_names.index(n) for n in labelled]
        cells, angles = data["cells"].astype(np.float64), data["angles"].astype(np.float64)
        assert np.isnan(angles[:, [d for d in range(25) if d not in columns]]).all()
        subject, session, glove, kind = data["subject"], data["session"], data["glove"], data["kind"]

        # Training runs in the order of their first frame; the last of them, about 10% of the
        # frames (at least one run, never all), validate and are not trained on.
        order, counts = [], {}
        for key in zip(subject, glove, session, kind):
            if key[3] == 0 and key[0] != 3:
                if key[:3] not in counts:
                    order.append(key[:3])
                counts[key[:3]] = counts.get(key[:3], 0) + 1
        held, held_frames = set(), 0
        for key in reversed(order[1:]):
            if held_frames >= 0.1 * sum(counts.values()):
                break
            held.add(key)
            held_frames += counts[key]
        xs, ys, test_x, test_y = [], [], [], []
        for key in sorted(set(zip(subject, glove, session))):
            run_frames = (subject == key[0]) & (glove == key[1]) & (session == key[2])
            x = calibrated(cells[run_frames & (kind == 0)], cells[run_frames & (kind == 1)], window, flat)
            y = angles[run_frames & (kind == 0)][:, columns]
            if key[0] == 3:
                test_x.append(x), test_y.append(y)
            elif key not in held:
                xs.append(x), ys.append(y)
        x, y = np.vstack(xs), np.vstack(ys)
        design = np.hstack([x, np.ones((len(x), 1))])
        w, *_ = np.linalg.lstsq(design, y, rcond=None)
        tx, ty = np.vstack(test_x), np.vstack(test_y)
        predicted = np.hstack([tx, np.ones((len(tx), 1))]) @ w
        # Kept within the model's joint limits, as glovepose keeps a linear map's angles.
        _, linear_meta = read_safetensors(os.path.join(work, "linear.safetensors"))
        lo = np.array(json.loads(linear_meta["joint_limits_min"]))[columns]
        hi = np.array(json.loads(linear_meta["joint_limits_max"]))[columns]
        predicted = np.clip(predicted, lo, hi)
        reference = float(np.mean(np.abs(predicted - ty)) * 180.0 / math.pi)

        def mean_of(model):
            out = run(f"build/tools/glovepose eval --model {model} --data mydata.safetensors --subjects 3 --json", work)
            return json.loads(out)["mean_deg"], json.loads(out)["scored_dofs"]

        linear, scored = mean_of("linear.safetensors")
        unet, _ = mean_of("unet.safetensors")
    print(f"calibration: {window}-frame median, flat below {flat}")
    print(f"least squares here: {reference:.4f} deg; glovepose linear {linear:.4f} deg; U-Net {unet:.4f} deg; {scored} DoFs scored")
    failures = []
    if scored != 21:
        failures.append(f"eval scored {scored} DoFs, expected the 21 labelled")
    if abs(linear - reference) > 0.01 * reference:
        failures.append(f"glovepose's linear map {linear:.4f} deg differs from the fit here {reference:.4f} by more than 1%")
    if not unet <= 1.1 * reference:
        failures.append(f"the U-Net's {unet:.4f} deg is worse than 1.1x the least-squares fit ({reference:.4f})")
    conclude(failures)


if __name__ == "__main__":
    main()
