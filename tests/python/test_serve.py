"""glovepose serve: a glove's poses to many programs at once. The device is this test
(glove_device.py: a simulated glove over a pty it closes and opens again); the engine stream's
clients decode it as docs/pose_stream.md lays it out (struct and zlib here, no code shared with the
service), and liblo's oscdump (Debian's liblo-tools) receives the OSC messages:
- the poses every reading client gets are those `predict --raw` computes from the very bytes the
  device sent (the same estimator, fed directly), to the 9 digits predict prints, with the same
  stream times, none missing;
- 8 clients at once, one of them stalled: the other 7 get every pose, and the service's own share
  of the latency (its --stats figure) is printed, bounded at 10 ms at p99 (the target is 2 ms);
- after each reopening of the pty, poses resume within 0.5 s, with the glove's profile kept;
- the profile made on the fly is saved, and applied when serve starts again;
- oscdump receives the documented messages with the estimator's angles;
- OpenGloves lines read from serve's pty, decoded as the protocol's documentation (opengloves-driver's
  wiki, "Driver Input") and docs/pose_stream.md say, give the curls and splays of the documented
  mapping of the estimator's angles (computed here from the hand model's published limits), while
  the "driver" writes force feedback back; VRChat's avatar parameters reach oscdump, at most 20 sets
  a second, with the same mapping's values;
- two gloves at once (--left, --right): each glove's poses, OpenGloves lines and profile are its
  own, the engine stream carries both hands;
- two live gloves, each on a pty reopened 6 times at random moments while both stream in real
  time, each with its viewer (--view): every pose of each hand is the estimator's, poses resume
  within 0.5 s of each reopening after the calibration, and each viewer's /state shows the
  calibration's steps, then the same poses;
- the engine stream's C client (bindings/c, its sample stream_print.c) and C# client
  (bindings/csharp/Runtime/PoseStream.cs, its sample Samples~/StreamPrint.cs, built with Mono's mcs)
  print the poses predict computes, by their sequence numbers, with the same stream times.

    GLOVEPOSE_CLI=build/tools/glovepose /usr/bin/python3 tests/python/test_serve.py
    ... test_serve.py --minutes 10 --reopen 20 --speed 1   (the long run: 10 minutes in real time)"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import shutil
import signal
import socket
import struct
import subprocess
import sys
import selectors
import threading
import time
import tty
import zlib
from pathlib import Path
from typing import List, Tuple

sys.path.insert(0, str(Path(__file__).resolve().parent))
from glove_device import PtyPort, free_port, play, run_with_options  # noqa: E402
from runner import Skip, Suite  # noqa: E402
from wire_doc import decode  # noqa: E402

CLI = os.environ.get("GLOVEPOSE_CLI", "")
STREAM_PRINT = os.environ.get("GLOVEPOSE_STREAM_PRINT", "")  # bindings/c/stream_print.c, built
CSHARP = Path(__file__).resolve().parents[2] / "bindings" / "csharp"
suite = Suite("glovepose_serve_")
OPTIONS = argparse.Namespace(minutes=0.5, reopen=4, speed=1.0)
MODEL = str(Path(__file__).resolve().parents[2] / "models" / "glovepose_fcn512.safetensors")  # serve's default
CALIBRATION_SECONDS = "10"
MESSAGE = struct.Struct("<2sBBIQdddHH25dI")  # docs/pose_stream.md, "The engine stream"


def setup_checks():
    if not CLI:
        raise Skip("GLOVEPOSE_CLI is not set")
    if shutil.which("oscdump") is None:
        raise Skip("oscdump (Debian's liblo-tools, tools/setup.sh) is not installed")


class Clients(threading.Thread):
    """Engine-stream clients, each reading every message, with the time it arrived: one thread for all
    of them (as an engine's one network thread), so that they take little of the machine's time."""

    def __init__(self, port: int, count: int, hands=(0,)):  # 0 right, 1 left: serve's --hand right by default
        super().__init__(daemon=True)
        self.hands = hands
        self.socks = [socket.create_connection(("127.0.0.1", port)) for _ in range(count)]
        self.messages: List[List[Tuple[float, tuple]]] = [[] for _ in range(count)]
        self.selector = selectors.DefaultSelector()
        for k, sock in enumerate(self.socks):
            self.selector.register(sock, selectors.EVENT_READ, k)
        self.buffers = [b""] * count
        self.start()

    def run(self):
        open_ = len(self.socks)
        while open_:
            for key, _ in self.selector.select():
                k = key.data
                try:
                    chunk = self.socks[k].recv(65536)
                except OSError:
                    chunk = b""
                if not chunk:
                    self.selector.unregister(self.socks[k])
                    open_ -= 1
                    continue
                now = time.monotonic()
                buffer = self.buffers[k] + chunk
                while len(buffer) >= MESSAGE.size:
                    fields = MESSAGE.unpack_from(buffer)
                    assert fields[0] == b"GH" and fields[1] == 1 and fields[2] in self.hands and fields[8] == 25 and fields[9] == 0, fields[:10]
                    assert fields[-1] == zlib.crc32(buffer[:MESSAGE.size - 4]), "a message's CRC"
                    self.messages[k].append((now, fields))
                    buffer = buffer[MESSAGE.size:]
                self.buffers[k] = buffer


def start_serve(args: List[str], stdin=None) -> Tuple[subprocess.Popen, int, List[str]]:
    serve = subprocess.Popen([CLI, "serve", *args, "--engine", "0", "--stats"], stdin=stdin, stderr=subprocess.PIPE, text=True)
    lines: List[str] = []
    port = 0
    while not port:
        line = serve.stderr.readline()
        assert line, f"serve ended: {lines}"
        lines.append(line)
        found = re.search(r"engine stream on 127\.0\.0\.1:(\d+)", line)
        port = int(found.group(1)) if found else 0
    threading.Thread(target=lambda: lines.extend(iter(serve.stderr.readline, "")), daemon=True).start()
    return serve, port, lines


def predict(stream: Path, calibration: List[str]) -> List[List[str]]:
    result = subprocess.run([CLI, "predict", "--model", MODEL, "--raw", "--in", str(stream), *calibration], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("thumb_base_abduction,"), lines[0]  # the header: the angles' names
    return [line.split(",") for line in lines[1:]]


def as_printed(angles) -> List[str]:
    return ["%.9g" % a for a in angles]


@suite.test
def poses_through_a_reopened_pty_equal_those_of_an_estimator_fed_directly():
    setup_checks()
    take = suite.tmp / "take.gpw"
    result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", str(OPTIONS.minutes), "--gloves", "1",
                             "--calibration-seconds", CALIBRATION_SECONDS, "--seed", "8", "--threads", "1", "--stream", str(take),
                             "--stream-payload", "cells", "--speed", "0", "--serial", "77"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    frames = decode(take.read_bytes())
    profiles = suite.tmp / "profiles"
    profiles.mkdir()
    port = PtyPort(suite.tmp / "glove-port")
    osc_port = free_port(socket.SOCK_DGRAM)
    osc_out = open(suite.tmp / "osc.txt", "w")
    oscdump = subprocess.Popen(["oscdump", "-L", str(osc_port)], stdout=osc_out, stderr=subprocess.STDOUT)
    serve, engine_port, log = start_serve(["--in", str(port.name), "--osc", f"127.0.0.1:{osc_port}", "--calibration-seconds",
                                           CALIBRATION_SECONDS, "--profiles", str(profiles), "--user", "ana"])
    clients = Clients(engine_port, 7)
    stalled = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 2048)  # fills after a few messages, and is never read
    stalled.connect(("127.0.0.1", engine_port))
    time.sleep(0.5)  # serve takes the clients before the first pose

    sent = bytearray()
    resumed_marks: List[float] = []

    def send(data: bytes):
        sent.extend(data)
        port.send(data)

    play(frames, send, port.reopen, OPTIONS.reopen, random.Random(11), OPTIONS.speed, reconnected=lambda: resumed_marks.append(time.monotonic()))
    time.sleep(0.5)
    serve.send_signal(signal.SIGINT)
    serve.wait(timeout=30)
    time.sleep(0.3)
    oscdump.terminate()
    oscdump.wait()
    osc_out.close()
    port.close()
    stalled.close()
    text = "".join(log)
    assert serve.returncode == 0, text

    # The reference: predict --raw on the bytes the device sent, the same calibration on the fly.
    delivered = suite.tmp / "delivered.gpw"
    delivered.write_bytes(bytes(sent))
    reference = predict(delivered, ["--calibration-seconds", CALIBRATION_SECONDS])
    assert len(reference) > 100, len(reference)
    for k, got in enumerate(clients.messages):
        assert len(got) == len(reference), f"client {k}: {len(got)} poses, predict made {len(reference)}"
        assert [f[4] for _, f in got] == list(range(got[0][1][4], got[0][1][4] + len(got))), f"client {k}: sequence numbers skip"
        for i, ((_, f), expected) in enumerate(zip(got, reference)):
            assert as_printed(f[10:35]) == expected, f"client {k}, pose {i}: {as_printed(f[10:35])[:3]} against {expected[:3]}"
        times = [f[5] for _, f in got]
        assert all(b > a for a, b in zip(times, times[1:])), f"client {k}: stream times go back"
    missed = int(re.search(r"(\d+) missed by clients that did not read", text).group(1))
    assert missed > 0, "the stalled client missed nothing: it was not stalled"

    # The service's own added latency, and each client's delivery time.
    latency = re.search(r"latency \(last byte read to pose sent\) over \d+ poses: p50 [0-9.]+ ms, p99 ([0-9.]+) ms; the service.s own "
                        r"\(its frame.s handling to the pose sent, less the estimator.s work\): p50 [0-9.]+ ms, p99 ([0-9.]+) ms", text)
    total_p99, p99 = float(latency.group(1)), float(latency.group(2))
    # The target is 2 ms. On a 2-core virtual machine shared with the clients, oscdump and this device,
    # runs measured p50 0.17-0.3 ms and p99 1.0-3.8 ms, the tail from stalls of the whole thread (even
    # real-time scheduled, it loses the CPU for 2-6 ms now and then: docs/pose_stream.md). 10 ms
    # catches a service that waits on a client or the disk per pose.
    assert p99 <= 10.0, f"serve adds {p99} ms at p99: {text}"
    delivery = sorted(arrived - f[7] for got in clients.messages for arrived, f in got)
    client_p99 = delivery[int(0.99 * len(delivery))] * 1e3

    # Poses resume after each reopening.
    arrivals = [arrived for arrived, _ in clients.messages[0]]
    waits = []
    for mark in resumed_marks:
        after = [t for t in arrivals if t > mark]
        assert after, "no pose after a reopening"
        waits.append(after[0] - mark)
    assert len(resumed_marks) == OPTIONS.reopen and max(waits) <= 0.5, waits
    opened = int(re.search(r"opened (\d+) time", text).group(1))
    assert opened == OPTIONS.reopen + 1, text

    # The profile was made on the fly and saved.
    profile = profiles / "glauser2019-44-77-ana.calibration"
    assert profile.exists() and "profile '" in text and "saved" in text, text

    # OSC: every pose's angles and time, as oscdump shows them (float32 printed with 6 decimals).
    osc = (suite.tmp / "osc.txt").read_text().splitlines()
    angles = [line.split()[3:] for line in osc if " /glovepose/right/angles fffffffffffffffffffffffff " in line]
    stamps = [line.split()[3:] for line in osc if " /glovepose/right/time hd " in line]
    assert len(angles) == len(reference) and len(stamps) == len(reference), (len(angles), len(stamps), len(reference))
    for a, expected in zip(angles, reference):
        assert all(abs(float(x) - struct.unpack("<f", struct.pack("<f", float(e)))[0]) <= 1e-6 for x, e in zip(a, expected)), (a[:3], expected[:3])
    assert [int(s[0]) for s in stamps] == [f[4] for _, f in clients.messages[0]]
    print(f"  {len(reference)} poses to 7 clients and OSC, a stalled client missed {missed}; {len(resumed_marks)} reopenings, poses back"
          f" after at most {max(waits) * 1e3:.0f} ms; serve adds p99 {p99:.3f} ms (read to sent, the estimator and backlogs included,"
          f" {total_p99:.3f} ms), delivery to a client p99 {client_p99:.3f} ms")


@suite.test
def a_saved_profile_is_applied_when_serve_starts_again():
    setup_checks()
    profiles = suite.tmp / "profiles"
    profile = profiles / "glauser2019-44-77-ana.calibration"
    if not profile.exists():
        raise Skip("needs the profile the test before saved")
    later = suite.tmp / "later.gpw"
    result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.2", "--gloves", "1", "--calibration-seconds",
                             "0", "--seed", "8", "--threads", "1", "--stream", str(later), "--stream-payload", "cells", "--speed", "0", "--serial",
                             "77"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    serve, engine_port, log = start_serve(["--in", "-", "--profiles", str(profiles), "--user", "ana"], stdin=subprocess.PIPE)
    client = Clients(engine_port, 1)
    time.sleep(0.3)  # serve takes the client before the first pose
    serve.stdin.buffer.write(later.read_bytes())
    serve.stdin.close()
    serve.wait(timeout=60)
    time.sleep(0.2)
    text = "".join(log)
    assert serve.returncode == 0, text
    assert f"profile '{profile}' applied" in text, text
    reference = predict(later, ["--calibration", str(profile)])
    # A stream read all at once makes poses faster than this client reads them: it misses some (the
    # sequence numbers say which), and gets the others as predict made them.
    got = client.messages[0]
    assert len(got) > 50 and got[-1][1][4] == len(reference), f"{len(got)} poses, the last {got[-1][1][4]}; predict made {len(reference)}"
    for _, f in got:
        assert as_printed(f[10:35]) == reference[f[4] - 1], f"pose {f[4]} differs from predict's"


HAND_MODEL = Path(__file__).resolve().parents[1] / "reference" / "hmodel_template.hpp"
FINGERS = ("thumb", "index", "middle", "ring", "pinky")


def documented_curls(angles: List[float]):
    """docs/pose_stream.md, "Curls and splays", from the hand model's published upper limits (the
    shipped model's): per finger the joint curls (OpenGloves' joints 0-3), the finger's curl and splay."""
    limits = {m.group(1): float(m.group(2)) for m in re.finditer(r'\{\d+, "(\w+)", \d+, \'[XYZ]\', [-0-9.]+, ([-0-9.]+)\}', HAND_MODEL.read_text())}
    names = list(limits)  # theta 9..33: the angles' order
    assert len(names) == 25 and names[0] == "thumb_base_abduction", names
    value = dict(zip(names, angles))
    out = []
    for finger in FINGERS:
        flex = [min(max(value[f"{finger}_{part}_flexion"] / limits[f"{finger}_{part}_flexion"], 0.0), 1.0) for part in ("base", "middle", "tip")]
        joints = flex if finger == "thumb" else [0.0] + flex
        splay = min(max(value[f"{finger}_base_abduction"] / math.radians(20.0), -1.0), 1.0)
        out.append((joints, sum(flex) / 3.0, splay))
    return out


def decode_opengloves(line: str, most: int):
    """An OpenGloves line as the wiki documents it: keys (a letter, or letters in brackets) each
    followed by digits, or alone for a button that is pressed. Returns {key: value / most}, splays
    mapped back to -1..1, a pressed button as True."""
    found = re.findall(r"(\([A-Z]+\)|[A-Z])(\d*)", line)
    assert "".join(k + v for k, v in found) == line, f"not keys and numbers: {line!r}"
    values = {}
    for key, digits in found:
        if not digits:
            values[key] = True
            continue
        fraction = int(digits) / most
        values[key] = (2.0 * fraction - 1.0) if re.fullmatch(r"\([A-E]B\)", key) else fraction
    return values


def documented_gestures(expected):
    """docs/pose_stream.md, "OpenGloves" (LucidGloves' firmware rules): from the fingers' curls, the
    trigger button I and its value P, grab L and pinch M; None where a mean is too near its edge for
    9 printed digits to decide."""
    curl = [c for _, c, _ in expected]
    means = {"I": curl[1], "L": sum(curl[1:]) / 4.0, "M": (curl[0] + curl[1]) / 2.0}
    if any(abs(m - 0.5) < 1e-6 for m in means.values()):
        return None
    return {key: m > 0.5 for key, m in means.items()}, (2.0 * curl[1] - 1.0 if curl[1] > 0.5 else 0.0)


@suite.test
def opengloves_lines_and_vrchat_parameters_carry_the_documented_curls_and_splays():
    setup_checks()
    take = suite.tmp / "opengloves.gpw"
    result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.2", "--gloves", "1", "--calibration-seconds",
                             "5", "--seed", "9", "--threads", "1", "--stream", str(take), "--stream-payload", "cells", "--speed", "0"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    reference = [[float(x) for x in row] for row in predict(take, ["--calibration-seconds", "5"])]
    link = suite.tmp / "glovepose-right"
    osc_port = free_port(socket.SOCK_DGRAM)
    osc_out = open(suite.tmp / "vrchat.txt", "w")
    oscdump = subprocess.Popen(["oscdump", "-L", str(osc_port)], stdout=osc_out, stderr=subprocess.STDOUT)
    log = open(suite.tmp / "opengloves-serve.txt", "w+")
    most = 1023
    serve = subprocess.Popen([CLI, "serve", "--in", "-", "--calibration-seconds", "5", "--opengloves", f"pty:{link}", "--opengloves-joints",
                              "--opengloves-max", str(most), "--vrchat", f"127.0.0.1:{osc_port}"], stdin=subprocess.PIPE, stderr=log)
    deadline = time.monotonic() + 30
    while not link.is_symlink():
        assert serve.poll() is None and time.monotonic() < deadline, log.seek(0) or log.read()
        time.sleep(0.02)
    driver = os.open(link, os.O_RDWR | os.O_NOCTTY)  # as a driver opens the glove's port
    tty.setraw(driver)
    received = bytearray()

    def read_lines():
        while True:
            try:
                chunk = os.read(driver, 4096)
            except OSError:
                return
            if not chunk:
                return
            received.extend(chunk)

    reader = threading.Thread(target=read_lines, daemon=True)
    reader.start()
    data = take.read_bytes()
    for at in range(0, len(data), 4096):  # about 20 frames at a time, at about 4 times the glove's rate
        if at % (4096 * 8) == 0:
            os.write(driver, b"A0B0C0D0E0\n")  # force feedback, as a driver sends it to the glove
        serve.stdin.write(data[at:at + 4096])
        serve.stdin.flush()
        time.sleep(0.08)
    serve.stdin.close()
    serve.wait(timeout=60)
    time.sleep(0.3)
    oscdump.terminate()
    oscdump.wait()
    osc_out.close()
    log.seek(0)
    text = log.read()
    assert serve.returncode == 0, text
    assert not link.exists() and not link.is_symlink(), "serve left its pty's link behind"
    os.close(driver)
    reader.join(timeout=5)

    # Every line read is the documented mapping of one of the estimator's poses, in order; lines the
    # reader missed are the ones serve counted as skipped.
    lines = bytes(received).decode("ascii").split("\n")
    assert lines[-1] == "", "a line was cut off"
    lines = lines[:-1]
    sent, skipped, failed, unread = map(int, re.search(r"OpenGloves: (\d+) lines sent, (\d+) skipped.*?, (\d+) failed.*?, (\d+) of those sent"
                                                       r" discarded unread", text).groups())
    assert sent + skipped + failed == len(reference) and failed == 0 and unread == 0, (sent, skipped, failed, unread, len(reference))
    assert len(lines) == sent and sent >= 0.9 * len(reference), (sent, len(lines), len(reference))
    joint_keys = [[f"({chr(65 + f)}A{chr(65 + j)})" for j in range(3 if f == 0 else 4)] for f in range(5)]
    worst = 0.0
    at = 0
    pressed_seen = {"I": 0, "L": 0, "M": 0}
    for line in lines:
        for key in pressed_seen:
            pressed_seen[key] += key in re.sub(r"\([A-Z]+\)", "", line)
        values = decode_opengloves(line, most)
        assert 10 + 1 + 3 + 16 <= len(values) <= 10 + 1 + 3 + 16 + 3, f"{len(values)} keys in {line!r}"
        assert len(line) + 1 <= 233, f"a line of {len(line) + 1} bytes, documented at most 233"
        best = None
        while at < len(reference):  # the next pose this line can be
            expected = documented_curls(reference[at])
            at += 1
            error = 0.0  # in the line's steps (1/most of a curl, 2/most of a splay)
            for f, (joints, curl, splay) in enumerate(expected):
                error = max(error, abs(values[chr(65 + f)] - curl) * most, abs(values[f"({chr(65 + f)}B)"] - splay) * most / 2)
                error = max([error] + [abs(values[k] - j) * most for k, j in zip(joint_keys[f], joints)])
            gestures = documented_gestures(expected)
            if gestures is not None:
                pressed, trigger = gestures
                error = max(error, abs(values["P"] - trigger) * most)
                if any(values.get(key, False) != on for key, on in pressed.items()):
                    error = math.inf
            if error <= 0.5 + 1e-4:  # rounded to the nearest step (predict prints 9 digits, not the doubles)
                best = error
                break
        assert best is not None, f"line {line!r} is no pose's documented curls and splays"
        worst = max(worst, best)

    # VRChat: sets of ten floats, at least 50 ms apart, each a pose's curls and splays.
    names = [f"/avatar/parameters/Right{f.capitalize()}{kind}" for f in FINGERS for kind in ("Curl", "Splay")]
    sets = []
    for line in (suite.tmp / "vrchat.txt").read_text().splitlines():
        stamp, address, types, value = line.split()
        assert address in names and types == "f", line
        seconds, fraction = stamp.split(".")
        if address == names[0]:
            sets.append((int(seconds, 16) + int(fraction, 16) / 2 ** 32, {}))
        sets[-1][1][address] = float(value)
    assert len(sets) >= 5, len(sets)
    gaps = [b[0] - a[0] for a, b in zip(sets, sets[1:])]
    assert min(gaps) >= 0.045, f"VRChat parameters {min(gaps) * 1e3:.1f} ms apart, expected at most 20 sets a second"
    at = 0
    for _, got in sets:
        assert len(got) == 10, got
        while True:
            assert at < len(reference), f"VRChat set {got} is no pose's curls and splays"
            expected = documented_curls(reference[at])
            at += 1
            if all(abs(got[names[2 * f]] - curl) <= 1e-6 and abs(got[names[2 * f + 1]] - splay) <= 1e-6 for f, (_, curl, splay) in enumerate(expected)):
                break
    assert pressed_seen["I"] and pressed_seen["L"], f"the gestures were never on: {pressed_seen}"
    print(f"  {len(lines)} OpenGloves lines of {len(reference)} poses decoded ({skipped} skipped), each within {worst:.3f} steps of the"
          f" documented mapping, gestures included (trigger in {pressed_seen['I']}, grab in {pressed_seen['L']}, pinch in"
          f" {pressed_seen['M']}); {len(sets)} VRChat parameter sets, at least {min(gaps) * 1e3:.0f} ms apart")


@suite.test
def two_gloves_each_get_their_own_poses_lines_and_profile():
    setup_checks()
    takes, references = {}, {}
    for hand, seed, serial in (("left", 12, 51), ("right", 13, 52)):
        takes[hand] = suite.tmp / f"two-{hand}.gpw"
        result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.2", "--gloves", "1",
                                 "--calibration-seconds", "5", "--seed", str(seed), "--threads", "1", "--stream", str(takes[hand]),
                                 "--stream-payload", "cells", "--speed", "0", "--serial", str(serial)], capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        references[hand] = predict(takes[hand], ["--calibration-seconds", "5"])
    assert references["left"] != references["right"]
    profiles = suite.tmp / "two-profiles"
    profiles.mkdir()
    serve, engine_port, log = start_serve(["--left", str(takes["left"]), "--right", str(takes["right"]), "--calibration-seconds", "5",
                                           "--opengloves", str(suite.tmp / "two-{hand}.txt"), "--opengloves-max", "1023",
                                           "--profiles", str(profiles), "--user", "ana"])
    # serve starts on the files at once: a client connected now gets what it can (the sequences say which).
    client = Clients(engine_port, 1, hands=(0, 1))
    serve.wait(timeout=60)
    time.sleep(0.3)
    text = "".join(log)
    assert serve.returncode == 0, text
    for hand, serial in (("left", 51), ("right", 52)):
        reference = references[hand]
        assert f"{hand}: {len(reference)} poses published" in text, text
        assert (profiles / f"glauser2019-44-{serial}-ana.calibration").exists(), text
        lines = (suite.tmp / f"two-{hand}.txt").read_text().splitlines()
        assert len(lines) == len(reference), (hand, len(lines), len(reference))
        for line, pose in zip(lines, reference):
            values = decode_opengloves(line, 1023)
            for f, (_, curl, splay) in enumerate(documented_curls([float(x) for x in pose])):
                assert abs(values[chr(65 + f)] - curl) * 1023 <= 0.5 + 1e-4 and abs(values[f"({chr(65 + f)}B)"] - splay) * 1023 / 2 <= 0.5 + 1e-4, (hand, line)
    got = client.messages[0]
    hands = {0: "right", 1: "left"}
    for _, fields in got:
        assert as_printed(fields[10:35]) == references[hands[fields[2]]][fields[4] - 1], f"{hands[fields[2]]} pose {fields[4]}"
    assert {fields[2] for _, fields in got} == {0, 1}, "the engine stream did not carry both hands"
    print(f"  two gloves: {len(references['left'])} + {len(references['right'])} poses, each glove's OpenGloves lines and profile its own;"
          f" an engine client got {len(got)} messages of both hands")


def viewer_get(port: int, path: str = "/state") -> dict:
    """GET /state or /meta of a viewer page (docs/own_glove.md, "Live viewing")."""
    with socket.create_connection(("127.0.0.1", port), timeout=2) as sock:
        sock.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
        data = b""
        while chunk := sock.recv(65536):
            data += chunk
    head, _, body = data.partition(b"\r\n\r\n")
    assert head.startswith(b"HTTP/1.1 200"), head
    return json.loads(body)


@suite.test
def two_live_gloves_through_reopened_ptys_each_with_its_viewer():
    setup_checks()
    frames, ports, sent, resumed = {}, {}, {}, {}
    REOPENINGS = 6  # noqa: N806 - a constant of this test
    for hand, seed, serial in (("left", 21, 61), ("right", 22, 62)):
        take = suite.tmp / f"live-{hand}.gpw"
        result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.35", "--gloves", "1",
                                 "--calibration-seconds", CALIBRATION_SECONDS, "--seed", str(seed), "--threads", "1", "--stream", str(take),
                                 "--stream-payload", "cells", "--speed", "0", "--serial", str(serial)], capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        frames[hand] = decode(take.read_bytes())
        ports[hand] = PtyPort(suite.tmp / f"live-{hand}-port")
        sent[hand], resumed[hand] = bytearray(), []
    serve, engine_port, log = start_serve(["--left", str(ports["left"].name), "--right", str(ports["right"].name), "--calibration-seconds",
                                           CALIBRATION_SECONDS, "--view", "0"])
    views = {m.group(1): int(m.group(2)) for m in re.finditer(r"serve: (left|right): viewer on http://127\.0\.0\.1:(\d+)/", "".join(log))}
    assert set(views) == {"left", "right"} and views["left"] != views["right"], log
    sequence = viewer_get(views["left"], "/meta")["steps"]  # the model's calibration sequence, if it has one
    client = Clients(engine_port, 1, hands=(0, 1))
    time.sleep(0.5)

    def device(hand: str, seed: int):
        def send(data: bytes):
            sent[hand].extend(data)
            ports[hand].send(data)
        play(frames[hand], send, ports[hand].reopen, REOPENINGS, random.Random(seed), 1.0,
             reconnected=lambda: resumed[hand].append(time.monotonic()))

    devices = [threading.Thread(target=device, args=(hand, seed)) for hand, seed in (("left", 31), ("right", 32))]
    for d in devices:
        d.start()
    states = {"left": [], "right": []}  # what each viewer showed, polled while the gloves stream
    while any(d.is_alive() for d in devices):
        for hand, port in views.items():
            states[hand].append(viewer_get(port))
        time.sleep(0.2)
    for d in devices:
        d.join()
    time.sleep(0.5)
    serve.send_signal(signal.SIGINT)
    serve.wait(timeout=30)
    for port in ports.values():
        port.close()
    time.sleep(0.3)
    text = "".join(log)
    assert serve.returncode == 0, text

    hands = {0: "right", 1: "left"}
    for hand in ("left", "right"):
        delivered = suite.tmp / f"live-{hand}-delivered.gpw"
        delivered.write_bytes(bytes(sent[hand]))
        reference = predict(delivered, ["--calibration-seconds", CALIBRATION_SECONDS])
        got = [(arrived, f) for arrived, f in client.messages[0] if hands[f[2]] == hand]
        # Every pose of the glove, the estimator's, in order, none missing.
        assert len(got) == len(reference), (hand, len(got), len(reference))
        for (_, f), expected in zip(got, reference):
            assert as_printed(f[10:35]) == expected, f"{hand} pose {f[4]}"
        # After each reopening of its pty once poses flow (not during the calibration, which has none),
        # the glove's poses resume within 0.5 s.
        assert len(resumed[hand]) == REOPENINGS
        marks = [mark for mark in resumed[hand] if mark > got[0][0]]
        assert len(marks) >= 2, (hand, len(marks))
        waits = [min(t for t, _ in got if t > mark) - mark for mark in marks]
        assert max(waits) <= 0.5, (hand, waits)
        assert re.search(rf"serve: {hand}: \d+ poses published; link: .*opened {REOPENINGS + 1} times", text), text
        # Its viewer: calibrating first (with the step under way when the model has a sequence), then
        # the estimator's poses, the same ones the engine stream carried.
        shown = states[hand]
        calibrating = [st for st in shown if st["calibrating"]]
        assert calibrating, f"{hand}: the viewer never showed the calibration"
        posed = [st for st in shown if st.get("seq")]
        assert len(posed) >= 20, (hand, len(posed))
        for st in posed:
            assert as_printed(st["angles"]) == reference[st["seq"] - 1], f"{hand} viewer pose {st['seq']}"
        assert all(b["seq"] >= a["seq"] for a, b in zip(posed, posed[1:]))
        with_step = [st for st in calibrating if st["step"] >= 0]
        if sequence:
            assert with_step and all(st["instruction"] for st in with_step), f"{hand}: the viewer showed no step of the sequence"
        print(f"  {hand}: {len(got)} poses, the estimator's, through {REOPENINGS} reopenings ({len(marks)} after the calibration, poses back"
              f" after at most {max(waits) * 1e3:.0f} ms); its viewer"
              f" showed {len(calibrating)} calibrating states ({len(with_step)} with a step), then {len(posed)} poses equal to the stream's")


@suite.test
def the_c_and_csharp_clients_read_the_estimators_poses():
    setup_checks()
    if not STREAM_PRINT or shutil.which("mcs") is None or shutil.which("mono") is None:
        raise Skip("needs GLOVEPOSE_STREAM_PRINT (the C client's sample) and Mono's mcs and mono (Debian's mono-mcs)")
    printer = suite.tmp / "StreamPrint.exe"
    built = subprocess.run(["mcs", "-nologo", "-unsafe", "-warnaserror", f"-out:{printer}", *map(str, sorted((CSHARP / "Runtime").glob("*.cs"))),
                            str(CSHARP / "Samples~" / "StreamPrint.cs")], capture_output=True, text=True)
    assert built.returncode == 0, built.stdout + built.stderr
    take = suite.tmp / "clients.gpw"
    result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "0.2", "--gloves", "1", "--calibration-seconds",
                             "5", "--seed", "10", "--threads", "1", "--stream", str(take), "--stream-payload", "cells", "--speed", "0"],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    reference = predict(take, ["--calibration-seconds", "5"])
    serve, engine_port, log = start_serve(["--in", "-", "--calibration-seconds", "5"], stdin=subprocess.PIPE)
    clients = {"C": subprocess.Popen([STREAM_PRINT, "127.0.0.1", str(engine_port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True),
               "C#": subprocess.Popen(["mono", str(printer), "127.0.0.1", str(engine_port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      text=True)}
    time.sleep(2.0)  # mono starts, both connect before the first pose
    data = take.read_bytes()
    for at in range(0, len(data), 4096):  # at about twice the glove's rate: the clients keep up
        serve.stdin.buffer.write(data[at:at + 4096])
        serve.stdin.buffer.flush()
        time.sleep(0.16)
    serve.stdin.close()
    serve.wait(timeout=60)
    assert serve.returncode == 0, "".join(log)
    for name, client in clients.items():
        out, err = client.communicate(timeout=30)
        assert client.returncode == 0, f"{name} client: {err}"
        rows = [line.split(",") for line in out.splitlines()]
        assert len(rows) >= 0.9 * len(reference), f"{name} client: {len(rows)} poses of {len(reference)}"
        sequences = [int(row[0]) for row in rows]
        assert sequences == sorted(set(sequences)) and sequences[-1] <= len(reference), f"{name} client: {len(sequences)} sequences, {sequences[:3]}...{sequences[-3:]}, predict made {len(reference)}"
        for row in rows:
            assert ["%.9g" % float(x) for x in row[2:]] == reference[int(row[0]) - 1], f"{name} client, pose {row[0]} differs from predict's"
        times = [float(row[1]) for row in rows]
        assert all(b > a for a, b in zip(times, times[1:])), f"{name} client: stream times go back"
        print(f"  {name} client: {len(rows)} poses of {len(reference)}, each predict's")


@suite.test
def the_clients_read_split_messages_and_stop_at_a_corrupt_one():
    """A stand-in service, its messages made from docs/pose_stream.md's table (struct and zlib here):
    a message sent in two parts is read whole; one with a flipped byte is refused, not printed."""
    setup_checks()
    printer = suite.tmp / "StreamPrint.exe"
    if not STREAM_PRINT or not printer.exists() or shutil.which("mono") is None:
        raise Skip("needs the C client's sample and StreamPrint.exe (built by the test before)")

    def message(sequence: int) -> bytes:
        angles = [0.01 * sequence + 0.001 * d for d in range(25)]
        body = struct.pack("<2sBBIQdddHH25d", b"GH", 1, 1, 0, sequence, sequence / 60.0, 100.0 + sequence / 60.0, 100.5, 25, 0, *angles)
        return body + struct.pack("<I", zlib.crc32(body))

    for name, command in (("C", [STREAM_PRINT]), ("C#", ["mono", str(printer)])):
        listener = socket.create_server(("127.0.0.1", 0))
        port = listener.getsockname()[1]
        client = subprocess.Popen([*command, "127.0.0.1", str(port)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        connection, _ = listener.accept()
        first, second, third = message(1), message(2), bytearray(message(3))
        connection.sendall(first)
        connection.sendall(second[:100])  # the rest a moment later: the client waits for the whole message
        time.sleep(0.3)
        connection.sendall(second[100:])
        third[60] ^= 0x01  # one bit of an angle: the CRC no longer matches
        connection.sendall(bytes(third))
        out, err = client.communicate(timeout=30)
        connection.close()
        listener.close()
        rows = [line.split(",") for line in out.splitlines()]
        assert [int(r[0]) for r in rows] == [1, 2], f"{name} client printed {out!r}"
        sent = [2 / 60.0] + [0.01 * 2 + 0.001 * d for d in range(25)]
        assert ["%.9g" % float(x) for x in rows[1][1:]] == ["%.9g" % v for v in sent], f"{name} client: {rows[1]}"
        assert re.search(r"bad message|BadMessage", err), f"{name} client: {err!r}"


@suite.test
def serve_given_nothing_to_do_says_so():
    setup_checks()
    for args, says in ((["--in", "-"], "nothing to serve to"), (["--in", "-", "--engine", "0", "--profiles", str(suite.tmp)], "needs --user"),
                       (["--engine", "0"], "no glove"), (["--left", "-", "--right", "-", "--engine", "0"], "both read stdin"),
                       (["--left", "a", "--right", "b", "--opengloves", "x.txt"], "expected '{hand}'")):
        result = subprocess.run([CLI, "serve", *args], capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=30)
        assert result.returncode != 0 and says in result.stderr, (args, result.stderr)


if __name__ == "__main__":
    sys.exit(run_with_options(suite, OPTIONS, "reopenings of the pty"))
