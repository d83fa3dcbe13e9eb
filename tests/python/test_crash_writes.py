"""Files that nothing can lose: `glovepose simulate --out`, `import`, `predict --save-calibration`
and `train --resume` killed (SIGKILL) at random moments, half of them while a file is being
written, and a model written onto a full disk. After every kill the output path holds the complete
previous file or the complete new one (byte for byte the uninterrupted run's), never a part; the
next `train --resume` goes on from the checkpoint the kills left, and the run after the last kill
ends with the model of a run that never stopped, byte for byte (its weights and validation
history); after a successful run no temporary file or checkpoint is left; a full disk gives an
error naming the file and the cause, a non-zero exit and the old file intact.

    GLOVEPOSE_CLI=build/tools/glovepose GLOVEPOSE_SLOW_FSYNC=build/tools/libglovepose_slow_fsync.so \
        /usr/bin/python3 tests/python/test_crash_writes.py [--kills N] [--seed S]

CTest runs 6 kills per command, with GLOVEPOSE_SLOW_FSYNC naming the build's
libglovepose_slow_fsync.so (its kills aimed at a write then land in it); `--kills 50` is the long
run (docs/testing.md)."""

from __future__ import annotations

import argparse
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable, List, Optional

sys.path.insert(0, str(Path(__file__).resolve().parent))
from runner import Skip, Suite  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CLI = os.environ.get("GLOVEPOSE_CLI", "")
# A library whose fsync() sleeps first (tests/slow_fsync.cpp), preloaded into the runs killed while
# they write: a calibration file of a few hundred bytes otherwise lives as a temporary file for
# microseconds, and a kill aimed at it lands there in a few runs of a hundred.
SLOW_FSYNC = os.environ.get("GLOVEPOSE_SLOW_FSYNC", "")
MODEL = str(ROOT / "models" / "glovepose_fcn512.safetensors")

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--kills", type=int, default=6, help="kills per command (default 6)")
parser.add_argument("--seed", type=int, default=1, help="seed of the kill moments")
args = parser.parse_args()
rng = random.Random(args.seed)
suite = Suite("glovepose_crash_")


def run(command: List[str], stdin: Optional[str] = None) -> None:
    with open(stdin or os.devnull, "rb") as f:
        result = subprocess.run(command, stdin=f, capture_output=True, text=True)
    if result.returncode != 0:
        raise AssertionError(f"{' '.join(command)} exited {result.returncode}: {result.stderr[-2000:]}")


def partials(target: Path) -> List[str]:
    """The temporary files of `target` in its folder."""
    prefix = target.name + ".partial-"
    return sorted(n for n in os.listdir(target.parent) if n.startswith(prefix))


class Scenario:
    """One command writing `target`: `command(variant)` writes the old file (variant 0) or the new
    one (1), byte for byte the same at every uninterrupted run."""

    def __init__(self, name: str, target: Path, command: Callable[[int], List[str]], stdin: Callable[[int], Optional[str]]) -> None:
        self.name, self.target, self.command, self.stdin = name, target, command, stdin
        self.checkpoint = target.with_name(target.name + ".checkpoint")  # train's

    def complete_run(self, variant: int) -> bytes:
        run(self.command(variant), self.stdin(variant))
        return self.target.read_bytes()

    def kill_once(self, during_write: bool, duration: float) -> bool:
        """Starts the new file's command, kills it; True when a temporary file existed at the kill."""
        before = set(partials(self.target) + partials(self.checkpoint))
        env = dict(os.environ, LD_PRELOAD=SLOW_FSYNC) if during_write and SLOW_FSYNC else None
        with open(self.stdin(1) or os.devnull, "rb") as f:
            process = subprocess.Popen(self.command(1), stdin=f, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
            if during_write:  # wait for the write to start, then a few milliseconds more at most
                deadline = time.monotonic() + 3 * duration + 5
                while process.poll() is None and time.monotonic() < deadline and not (set(partials(self.target) + partials(self.checkpoint)) - before):
                    time.sleep(0.0005)
                time.sleep(rng.uniform(0.0, 0.004))
            else:
                time.sleep(rng.uniform(0.0, 1.1 * duration))
            writing = bool(set(partials(self.target) + partials(self.checkpoint)) - before) and process.poll() is None
            process.send_signal(signal.SIGKILL)
            process.wait()
        return writing

    def check(self) -> None:
        old = self.complete_run(0)
        new = self.complete_run(1)
        assert old != new, f"{self.name}: the old and the new file are the same, expected two different files"
        start = time.monotonic()
        self.complete_run(1)
        duration = time.monotonic() - start
        mid_write = resumed = 0
        for k in range(args.kills):
            self.target.write_bytes(old)
            resumed += self.checkpoint.exists()
            mid_write += self.kill_once(during_write=k % 2 == 1, duration=duration)
            now = self.target.read_bytes()
            assert now in (old, new), f"{self.name}: after kill {k + 1} the file is neither the old nor the new one ({len(now)} bytes)"
        left = partials(self.target) + partials(self.checkpoint)
        print(f"  {self.name}: {args.kills} kills, {mid_write} while a file was being written, {resumed} runs going on from a "
              f"checkpoint, {len(left)} temporary files left by them")
        assert mid_write >= 1, f"{self.name}: no kill landed while the file was being written"
        final = self.complete_run(1)
        assert final == new, f"{self.name}: the run after the kills wrote another file than the run that never stopped"
        left = partials(self.target) + partials(self.checkpoint)
        assert not left, f"{self.name}: temporary files left after a successful run: {left}"
        assert not self.checkpoint.exists(), f"{self.name}: the checkpoint is left after the run ended"


_files: dict = {}


def setup() -> dict:
    """Made once for every check."""
    if not CLI:
        raise Skip("GLOVEPOSE_CLI is not set")
    if _files:
        return _files
    tmp = suite.tmp
    files = _files
    for variant in (0, 1):  # two small corpora, and each one's frames as CSV and as a raw stream
        data, csv = tmp / f"corpus{variant}.safetensors", tmp / f"corpus{variant}.csv"
        run([CLI, "simulate", "--subjects", "1", "--sessions", "2", "--minutes", "1", "--gloves", "1", "--calibration-seconds", "10",
             "--seed", str(variant + 1), "--threads", "1", "--out", str(data), "--csv", str(csv)])
        lines = csv.read_text().splitlines()
        cells = [i for i, name in enumerate(lines[0].split(",")) if name.startswith("cell_")]
        stream = tmp / f"stream{variant}.csv"
        with open(stream, "w") as f:
            for line in lines[1:]:
                values = line.split(",")
                f.write(values[2] + "," + ",".join(values[i] for i in cells) + "\n")
        files[variant] = (data, csv, stream)
    return files


@suite.test
def kills_leave_the_old_file_or_the_new_one():
    files = setup()
    out = suite.tmp / "out"
    out.mkdir()
    scenarios = [
        Scenario("simulate --out", out / "simulated.safetensors",
                 lambda v: [CLI, "simulate", "--subjects", "2", "--sessions", "2", "--minutes", "1", "--gloves", "1", "--threads", "1",
                            "--seed", str(v + 5), "--out", str(out / "simulated.safetensors")], lambda v: None),
        Scenario("import", out / "imported.safetensors",
                 lambda v: [CLI, "import", str(files[v][1]), "--rate", "60", "--out", str(out / "imported.safetensors")], lambda v: None),
        Scenario("predict --save-calibration", out / "user.calibration",
                 lambda v: [CLI, "predict", "--model", MODEL, "--raw", "--calibration-seconds", "10", "--save-calibration",
                            str(out / "user.calibration")], lambda v: str(files[v][2])),
        Scenario("train --resume", out / "model.safetensors",
                 lambda v: [CLI, "train", "--data", str(files[v][0]), "--architecture", "fcn:128", "--epochs", "20", "--threads", "1",
                            "--checkpoint-minutes", "0.003", "--quiet", "--resume", "--out", str(out / "model.safetensors")], lambda v: None),
    ]
    for scenario in scenarios:
        scenario.check()


@suite.test
def train_killed_five_times_and_resumed_ends_as_the_run_that_never_stopped():
    files = setup()
    target = suite.tmp / "resumed" / "model.safetensors"
    target.parent.mkdir()
    checkpoint = target.with_name(target.name + ".checkpoint")
    command = [CLI, "train", "--data", str(files[1][0]), "--architecture", "fcn:128", "--epochs", "20", "--threads", "1",
               "--checkpoint-minutes", "0.003", "--quiet", "--resume", "--out", str(target)]
    start = time.monotonic()
    run(command)
    duration = time.monotonic() - start
    whole = target.read_bytes()
    target.unlink()
    kills = 0
    for attempt in range(20):  # each run killed a short while after it went on: 5 kills within one run's time
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(0.06, 0.15) * duration)
        process.send_signal(signal.SIGKILL)
        process.wait()
        if target.exists():  # it ended before the kill: written once, at the end
            assert not checkpoint.exists(), "the checkpoint is left after the run ended"
            break
        kills += checkpoint.exists()
        if kills == 5:
            break
    print(f"  train: {kills} kills that left a checkpoint, in {attempt + 1} attempts")
    assert kills == 5, f"only {kills} kills landed before training ended"
    run(command)
    assert target.read_bytes() == whole, "the resumed run's model (weights, validation history) differs from the run that never stopped"
    assert not checkpoint.exists() and not partials(target) and not partials(checkpoint), "files left after the run ended"


@suite.test
def a_full_disk_keeps_the_old_model():
    files = setup()
    if shutil.which("unshare") is None:
        raise Skip("no unshare (util-linux) to mount a small tmpfs")
    old = suite.tmp / "old.safetensors"
    run([CLI, "train", "--data", str(files[0][0]), "--architecture", "linear", "--out", str(old)])
    disk = suite.tmp / "disk"
    disk.mkdir()
    page = 4096
    size = (old.stat().st_size + page - 1) // page * page + page  # the old model and one page: the new one cannot fit
    target = disk / "model.safetensors"
    script = (f"mount -t tmpfs -o size={size} tmpfs '{disk}' || exit 99; cp '{old}' '{target}'; "
              f"'{CLI}' train --data '{files[1][0]}' --architecture linear --out '{target}'; "
              f"echo \"exit=$?\"; cmp -s '{old}' '{target}' && echo same; ls -A '{disk}'")
    result = None
    for flags in (["-m"], ["-r", "-m"]):  # as root, else in a user namespace
        result = subprocess.run(["unshare", *flags, "sh", "-c", script], capture_output=True, text=True)
        if "exit=" in result.stdout:
            break
    if result is None or "exit=" not in result.stdout:
        raise Skip(f"cannot mount a tmpfs here: {result.stderr.strip() if result else ''}")
    out = result.stdout.split()
    print(f"  full disk ({size} bytes): {result.stderr.strip()}")
    assert "exit=0" not in out, "train exited 0 on a full disk"
    assert f"model file '{target}': cannot write: No space left on device" in result.stderr, f"the error: {result.stderr!r}"
    assert "same" in out, "the old model changed"
    assert out[-1] == "model.safetensors" and not any(".partial-" in w for w in out), f"left on the disk: {out}"


sys.exit(suite.run())
