"""The simulator as a device and the tool as its reader, through the wire protocol. The decoder (wire_doc.py)
is written from docs/wire_protocol.md (struct and zlib's CRC-32), sharing no code with the C++
encoder or parser:
- `glovepose simulate --stream` writes frames that decode with valid CRCs, a Hello naming the glove,
  contiguous sequence numbers and device times that advance one readout cycle per frame;
- `glovepose predict --raw` on the frames prints the very poses (byte for byte) it prints for the
  same readings as text lines made by this decoder, for raw rows and for cells;
- with one byte in 10,000 flipped, predict drops exactly the frames this decoder finds damaged and
  counts them as lost, and every frame it did not drop is used;
- record flushes every frame to the disk within 1 s of writing it (its system calls, seen by strace);
- through a pty pair the bytes arrive unchanged (the target is put in raw mode), and --speed paces
  the stream in real time.

    GLOVEPOSE_CLI=build/tools/glovepose /usr/bin/python3 tests/python/test_wire_stream.py"""

from __future__ import annotations

import json
import os
import random
import re
import shutil
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import List, Tuple

sys.path.insert(0, str(Path(__file__).resolve().parent))
from runner import Skip, Suite  # noqa: E402
from wire_doc import Frame, decode, encode  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CLI = os.environ.get("GLOVEPOSE_CLI", "")
MODEL = str(ROOT / "models" / "glovepose_fcn512.safetensors")
suite = Suite("glovepose_wire_")
SIM = ["simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.5", "--gloves", "1", "--calibration-seconds", "10",
       "--seed", "6", "--threads", "1"]


def simulate(path: Path, payload: str) -> List[Frame]:
    result = subprocess.run([CLI, *SIM, "--stream", str(path), "--stream-payload", payload, "--speed", "0"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return decode(path.read_bytes())


def as_lines(frames: List[Frame]) -> str:
    """The frames' readings as the text lines predict --raw reads, times in seconds of the device clock."""
    out = []
    for f in frames[1:]:
        t = f.device_us * 1e-6
        if f.kind == 2:  # rows: row u16, offset u16, value f32
            for row, offset, value in struct.iter_unpack("<HHf", f.payload):
                out.append(f"{row},{value!r},{t + offset * 1e-6!r}")
        elif f.kind == 4:  # cells
            out.append(",".join([repr(t)] + [repr(v) for (v,) in struct.iter_unpack("<f", f.payload)]))
        else:
            raise AssertionError(f"unexpected kind {f.kind}")
    return "\n".join(out) + "\n"


def predict(path: Path) -> Tuple[str, str]:
    result = subprocess.run([CLI, "predict", "--model", MODEL, "--raw", "--calibration-seconds", "10", "--in", str(path)],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return result.stdout, result.stderr


def link_counts(stderr: str) -> dict:
    line = next(l for l in stderr.splitlines() if ": link: " in l)
    return {name: int(n) for n, name in re.findall(r"(\d+) (frames passed on|bytes skipped|bad headers|bad payloads|lost|duplicated|late|restarts)", line)}


def setup_checks():
    if not CLI:
        raise Skip("GLOVEPOSE_CLI is not set")


@suite.test
def simulated_frames_decode_as_documented():
    setup_checks()
    for payload, kind, size in (("rows", 2, 180 * 8), ("measurements", 3, 180 * 4), ("cells", 4, 44 * 4)):
        frames = simulate(suite.tmp / f"{payload}.gpw", payload)
        hello = frames[0]
        assert hello.kind == 1 and hello.sequence == 0, hello[:3]
        serial, rows, cells, id_length = struct.unpack_from("<IHHB", hello.payload)
        glove = hello.payload[9:9 + id_length].decode()
        assert (serial, rows, cells, len(hello.payload)) == (1, 0 if payload == "cells" else 180, 44, 9 + id_length), (serial, rows, cells)
        assert glove == "glauser2019-44", glove
        readings = frames[1:]
        assert len(readings) == 60 * 40, len(readings)  # 10 s of calibration and 30 s of session at 60 Hz
        assert all(f.kind == kind and len(f.payload) == size for f in readings)
        assert [f.sequence for f in frames] == list(range(len(frames)))
        steps = {b.device_us - a.device_us for a, b in zip(readings, readings[1:])}
        assert steps <= {16666, 16667}, sorted(steps)  # one readout cycle, also from the calibration into the session
        if payload == "rows":
            offsets = [o for _, o, _ in struct.iter_unpack("<HHf", readings[0].payload)]
            assert offsets[0] == 0 and offsets == sorted(offsets) and offsets[-1] in (16574, 16575), offsets[-3:]  # 179 of 180 row slots


@suite.test
def frames_give_the_poses_of_the_same_readings_as_lines():
    setup_checks()
    for payload in ("rows", "cells"):
        wire = suite.tmp / f"same_{payload}.gpw"
        frames = simulate(wire, payload)
        text = suite.tmp / f"same_{payload}.csv"
        text.write_text(as_lines(frames))
        from_wire, told = predict(wire)
        from_text, _ = predict(text)
        assert from_wire.count("\n") > 1000, told
        assert from_wire == from_text, f"{payload}: the poses from frames differ from those of the same readings as lines"
        counts = link_counts(told)
        assert counts["frames passed on"] == len(frames) and sum(v for k, v in counts.items() if k != "frames passed on") == 0, counts


@suite.test
def damaged_frames_are_dropped_and_counted_lost():
    setup_checks()
    wire = suite.tmp / "damaged.gpw"
    frames = simulate(wire, "measurements")
    data = bytearray(wire.read_bytes())
    rng = random.Random(3)
    damaged = set()
    for i in range(frames[1].start, frames[-1].start):  # not the Hello, not the last frame (a loss no later frame reveals)
        if rng.random() < 1e-4:
            data[i] ^= rng.randrange(1, 256)
            damaged.add(next(k for k, f in enumerate(frames) if f.start <= i < f.end))
    assert len(damaged) >= 20, len(damaged)
    wire.write_bytes(bytes(data))
    poses, told = predict(wire)
    counts = link_counts(told)
    assert counts["lost"] == len(damaged), (counts, len(damaged))
    assert counts["frames passed on"] == len(frames) - len(damaged), counts
    assert counts["duplicated"] == counts["late"] == counts["restarts"] == 0, counts
    # every frame passed on is used: one pose per measurement frame from 10 s after the first one used
    used = [k for k in range(1, len(frames)) if k not in damaged]
    session = [k for k in used if frames[k].device_us - frames[used[0]].device_us >= 10_000_000]
    assert poses.count("\n") == 1 + len(session), (poses.count("\n"), len(session), len(damaged))  # and the header line


def hello(glove: str, rows: int = 180, cells: int = 44) -> bytes:
    return encode(1, 0, 0, struct.pack("<IHHB", 77, rows, cells, len(glove)) + glove.encode())


@suite.test
def another_glove_or_no_reading_is_an_error():
    setup_checks()
    cases = [
        (hello("someone-elses-glove"), "the device (serial 77) is glove 'someone-elses-glove' with 44 cells and 180 rows, expected glove "
                                       "'glauser2019-44' with 44 cells and 180 rows"),
        (hello("glauser2019-44", rows=90), "with 44 cells and 90 rows, expected glove 'glauser2019-44'"),
        (hello("glauser2019-44"), "no frame of stdin understood (1 frame)"),
        (hello("glauser2019-44") + encode(3, 1, 1000, struct.pack("<3f", 1, 2, 3)),
         "no pose computed from the 1 inputs of stdin (1 refused by the estimator, the first: frame 1: size mismatch"),
    ]
    calibration = suite.tmp / "user.calibration"  # a saved calibration, so that every frame could make a pose
    wire = suite.tmp / "for_calibration.gpw"
    simulate(wire, "cells")
    result = subprocess.run([CLI, "predict", "--model", MODEL, "--raw", "--calibration-seconds", "10", "--in", str(wire),
                             "--save-calibration", str(calibration)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    for stream, message in cases:
        result = subprocess.run([CLI, "predict", "--model", MODEL, "--raw", "--calibration", str(calibration)], input=stream, capture_output=True)
        err = result.stderr.decode()
        assert result.returncode != 0 and message in err, (result.returncode, err)


@suite.test
def record_and_import_give_the_simulated_cells():
    setup_checks()
    direct = suite.tmp / "direct.safetensors"
    short = [CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.1", "--gloves", "1", "--calibration-seconds", "0",
             "--seed", "6", "--threads", "1"]
    subprocess.run(short + ["--out", str(direct)], check=True, capture_output=True)
    for payload in ("cells", "measurements"):
        recording, dataset = (suite.tmp / f"take_{payload}{ext}" for ext in (".gpw", ".safetensors"))
        sim = subprocess.Popen(short + ["--stream", "-", "--speed", "0", "--stream-payload", payload], stdout=subprocess.PIPE,
                               stderr=subprocess.DEVNULL)
        result = subprocess.run([CLI, "record", "--out", str(recording)], stdin=sim.stdout, capture_output=True, text=True)
        sim.wait()
        assert result.returncode == 0 and "0 s: 60 frames, " in result.stderr, result.stderr  # the Hello and 59 frames in the first second
        assert f"{recording}: 361 frames, 6.0 s of device time" in result.stderr, result.stderr
        result = subprocess.run([CLI, "import", str(recording), "--subject", "0", "--rate", "60", "--out", str(dataset)],
                                capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        ours, theirs = dataset_cells(dataset), dataset_cells(direct)
        assert len(ours) == len(theirs) == 360, (len(ours), len(theirs))
        if payload == "cells":  # the cells as simulated, bit for bit
            assert ours == theirs, "the imported cells differ from the simulated ones"
        else:  # raw rows solved again by the importer's readout: close to the simulator's own solve
            worst = max(abs(a - b) for r, q in zip(ours[10:], theirs[10:]) for a, b in zip(r, q))
            assert worst < 0.5, worst  # pF, of cells around 8
    result = subprocess.run([CLI, "record", "--out", str(suite.tmp / "take_cells.gpw")], input=b"", capture_output=True)
    assert result.returncode != 0 and b"a recording never replaces a file" in result.stderr, result.stderr


def dataset_cells(path: Path) -> List[List[float]]:
    """The `cells` tensor (F32, frames x 44) of a dataset file (safetensors: a JSON header, then the data)."""
    data = path.read_bytes()
    (size,) = struct.unpack_from("<Q", data)
    tensor = json.loads(data[8:8 + size])["cells"]
    assert tensor["dtype"] == "F32", tensor
    start, end = tensor["data_offsets"]
    values = [v for (v,) in struct.iter_unpack("<f", data[8 + size + start:8 + size + end])]
    n = tensor["shape"][1]
    return [values[i:i + n] for i in range(0, len(values), n)]


@suite.test
def record_killed_at_twenty_moments_keeps_a_recording_that_imports():
    setup_checks()
    short = [CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.2", "--gloves", "1", "--calibration-seconds", "0",
             "--seed", "6", "--threads", "1", "--stream", "-", "--speed", "4"]
    rng = random.Random(9)
    worst_loss = 0.0
    for k in range(20):
        recording = suite.tmp / f"killed{k}.gpw"
        sim = subprocess.Popen(short, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        rec = subprocess.Popen([CLI, "record", "--quiet", "--out", str(recording)], stdin=subprocess.PIPE, stderr=subprocess.DEVNULL)
        handed = bytearray()  # every byte given to record before the kill
        first = sim.stdout.read1(65536)
        handed += first
        rec.stdin.write(first)
        rec.stdin.flush()
        deadline = time.monotonic() + rng.uniform(0.3, 2.0)
        while time.monotonic() < deadline:
            chunk = sim.stdout.read1(65536)
            if not chunk:
                break
            handed += chunk
            rec.stdin.write(chunk)
            rec.stdin.flush()
        rec.kill()
        rec.wait()
        sim.kill()
        sim.wait()
        kept = decode(recording.read_bytes(), cut_tail=True)
        sent = decode(bytes(handed), cut_tail=True)
        assert kept and kept[0].kind == 1 and len(kept) >= 2, f"kill {k}: {len(kept)} frames kept"
        assert [(f.sequence, f.payload) for f in kept] == [(f.sequence, f.payload) for f in sent[:len(kept)]], f"kill {k}: frames differ"
        loss = (sent[-1].device_us - kept[-1].device_us) * 1e-6
        worst_loss = max(worst_loss, loss)
        assert loss <= 1.0, f"kill {k}: {loss:.2f} s of device time handed to record is not in the recording"
        result = subprocess.run([CLI, "import", str(recording), "--subject", "0", "--rate", "60", "--out", str(suite.tmp / f"killed{k}.safetensors")],
                                capture_output=True, text=True)
        assert result.returncode == 0, f"kill {k}: {result.stderr}"
    print(f"  record: 20 kills, every recording imports; at most {worst_loss:.3f} s of what was handed to it missing")


@suite.test
def record_flushes_every_frame_to_the_disk_within_a_second():
    """The power-cut bound, read from the system calls record makes (strace, not record's own
    account): every write to the recording is followed by an fsync of it within 1 s, also when the
    stream pauses for 3 s after a frame."""
    setup_checks()
    if shutil.which("strace") is None:
        raise Skip("strace (Debian's strace, tools/setup.sh) is not installed")
    take = suite.tmp / "flush-take.gpw"
    subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.05", "--gloves", "1", "--calibration-seconds", "0",
                    "--seed", "6", "--threads", "1", "--stream", str(take), "--stream-payload", "cells", "--speed", "0"], check=True,
                   capture_output=True)
    frames = decode(take.read_bytes())
    recording = suite.tmp / "flushed.gpw"
    trace = suite.tmp / "record.strace"
    rec = subprocess.Popen(["strace", "-f", "-ttt", "-y", "-s", "0", "-e", "trace=write,fsync,fdatasync", "-e", "signal=none",
                            "-o", str(trace), CLI, "record", "--quiet", "--out", str(recording)], stdin=subprocess.PIPE,
                           stderr=subprocess.PIPE)
    start = time.monotonic()
    first_us = frames[1].device_us
    for k, f in enumerate(frames):
        if k == 120:
            time.sleep(3.0)  # the glove pauses: what came before must reach the disk meanwhile
            start += 3.0
        due = start + (f.device_us - first_us) * 1e-6
        if due > time.monotonic():
            time.sleep(due - time.monotonic())
        rec.stdin.write(encode(f.kind, f.sequence, f.device_us, f.payload))
        rec.stdin.flush()
    rec.stdin.close()
    err = rec.stderr.read()
    assert rec.wait(timeout=30) == 0, err.decode()
    name = re.escape(str(recording.resolve()))
    writes, syncs = [], []
    for line in trace.read_text().splitlines():
        found = re.match(rf"\d+ +([0-9.]+) (write|fsync|fdatasync)\(\d+<{name}>", line)
        if found:
            (writes if found.group(2) == "write" else syncs).append(float(found.group(1)))
    if not writes:
        raise Skip(f"strace saw no write to the recording (ptrace not allowed here?): {trace.read_text()[:300]}")
    assert syncs, "record never flushed the recording"
    waits = []
    for w in writes:
        later = [t for t in syncs if t >= w]
        assert later, f"a write at {w:.3f} was never flushed"
        waits.append(later[0] - w)
    assert max(waits) <= 1.0, f"a frame waited {max(waits):.3f} s for the disk"
    print(f"  record: {len(writes)} writes, {len(syncs)} fsyncs; every frame on the disk within {max(waits) * 1e3:.0f} ms of its write"
          f" (a 3 s pause included)")


@suite.test
def a_pty_carries_every_byte_and_speed_paces_the_stream():
    setup_checks()
    reference = suite.tmp / "reference.gpw"
    simulate(reference, "rows")
    master, slave = os.openpty()
    received = bytearray()

    def read_all():
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO once the last writer closed the slave
                return
            if not chunk:
                return
            received.extend(chunk)

    reader = threading.Thread(target=read_all)
    reader.start()
    result = subprocess.run([CLI, *SIM, "--stream", os.ttyname(slave), "--stream-payload", "rows", "--speed", "0"], capture_output=True, text=True)
    os.close(slave)
    reader.join(timeout=60)
    os.close(master)
    assert result.returncode == 0, result.stderr
    assert bytes(received) == reference.read_bytes(), f"{len(received)} bytes through the pty, {reference.stat().st_size} in the file"

    # 2 s of readings (no calibration) at real time, then at 4x
    short = [CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", str(2 / 60), "--gloves", "1", "--calibration-seconds", "0",
             "--seed", "6", "--threads", "1", "--stream", str(suite.tmp / "paced.gpw")]
    for speed, expected in (("1", 2.0), ("4", 0.5)):
        result = subprocess.run(short + ["--speed", speed], capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        took = float(re.search(r"bytes, in ([0-9.]+) s", result.stderr).group(1))
        assert expected - 0.05 <= took <= expected + 0.3, f"--speed {speed}: {took} s, expected {expected}"


if __name__ == "__main__":
    sys.exit(suite.run())
