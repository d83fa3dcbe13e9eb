#!/usr/bin/env python3
"""`glovepose view` in a real browser: headless Chromium (Debian's `chromium`) opens the page.

A recording with raw rows (a 2 s calibration, then a session) is written with `glovepose simulate`
and replayed by `glovepose view --port 0 --replay FILE` in real time. The test
(a) asks the tool's /state until a pose is there (JSON: 26 OpenXR joints, 25 angles, flags);
(b) takes a screenshot of the page and counts the hand's orange pixels in the WebGL canvas (the
    PNG is decoded here with zlib: no imaging library);
(c) reads the page's own state twice, a second apart (Chromium's --dump-dom: the page writes the
    frames it received, the pose sequence and the index fingertip into #status): WebGL is on, the
    page keeps receiving, the sequence grows and the fingertip moves: the drawing follows the stream;
(d) checks the server listens on the loopback address only;
(e) streams the same recording's rows as text lines on stdin to `glovepose view --stdin
    --calibration-seconds 2` (a real glove's path), paced at twice real time, after a line that is
    not a row: the hand is first calibrating, then posed, and its pose sequence grows while rows
    arrive; /state counts the skipped line and says why.

Run: /usr/bin/python3 tests/python/test_view.py   (GLOVEPOSE_CLI: the tool, default
build/tools/glovepose). Exit code 0 when every check passes; the last line reads 'N passed, N failed'.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.request
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CLI = Path(os.environ.get("GLOVEPOSE_CLI", ROOT / "build" / "tools" / "glovepose"))
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--window-size=1040,580",
                  "--virtual-time-budget=1500"]

passed = failed = 0


def check(condition: bool, what: str) -> None:
    global passed, failed
    if condition:
        passed += 1
    else:
        failed += 1
        print(f"FAILED: {what}")


def png_pixels(path: Path):
    """(width, height, rows of RGBA bytes) of an 8-bit RGB or RGBA PNG, non-interlaced."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and color in (2, 6) and interlace == 0, "expected 8-bit RGB(A), not interlaced"
            channels = 4 if color == 6 else 3
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, previous = [], bytearray(stride)
    for y in range(height):
        line = raw[y * (stride + 1):(y + 1) * (stride + 1)]
        kind, row = line[0], bytearray(line[1:])
        for i in range(stride):
            a = row[i - channels] if i >= channels else 0
            b = previous[i]
            c = previous[i - channels] if i >= channels else 0
            if kind == 1:
                row[i] = (row[i] + a) & 255
            elif kind == 2:
                row[i] = (row[i] + b) & 255
            elif kind == 3:
                row[i] = (row[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                row[i] = (row[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(row))
        previous = row
    return width, height, channels, rows


def read_rows(path: Path):
    """The raw rows (frames x 180, float32) and frame timestamps (float64) of a dataset file."""
    data = path.read_bytes()
    (header_length,) = struct.unpack("<Q", data[:8])
    header = json.loads(data[8:8 + header_length])
    body = data[8 + header_length:]

    def tensor(name: str, code: str):
        entry = header[name]
        begin, end = entry["data_offsets"]
        count = (end - begin) // struct.calcsize(code)
        return entry["shape"], struct.unpack(f"<{count}{code}", body[begin:end])

    (frames, rows), raw = tensor("raw_rows", "f")
    _, timestamps = tensor("timestamps", "d")
    return frames, rows, raw, timestamps


def get_state(url: str) -> dict:
    return json.loads(urllib.request.urlopen(url + "state", timeout=5).read())


def check_stdin(recording: Path) -> None:
    frames, rows, raw, timestamps = read_rows(recording)
    server = subprocess.Popen([str(CLI), "view", "--port", "0", "--seconds", "30", "--stdin", "--calibration-seconds", "2"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        match = re.search(r"http://127\.0\.0\.1:(\d+)/", server.stdout.readline())
        check(match is not None, "--stdin: the tool prints its address")
        if match is None:
            return
        url = f"http://127.0.0.1:{match.group(1)}/"
        period = 1.0 / (rows * 60.0)  # a row's slot in the 60 Hz readout cycle
        server.stdin.write("hello glove\n")  # not a row: skipped, counted and told
        seen_calibrating = False
        sequences = []
        for f in range(frames):
            lines = [f"{r},{raw[f * rows + r]!r},{timestamps[f] - (rows - 1 - r) * period!r}\n" for r in range(rows)]
            server.stdin.write("".join(lines))
            server.stdin.flush()
            time.sleep(1.0 / 120.0)
            if f % 30 == 29:
                state = get_state(url)
                seen_calibrating |= state.get("calibrating") is True
                if state.get("active") and not state.get("calibrating"):
                    sequences.append(state.get("seq", 0))
        for _ in range(50):  # the tool reads the last rows
            state = get_state(url)
            if state.get("lines") == frames * rows + 1:
                break
            time.sleep(0.1)
        check(seen_calibrating, "--stdin: the first 2 s of stream time calibrate")
        check(state.get("active") is True and not state.get("calibrating"), "--stdin: a calibrated pose after the calibration")
        check(len(state.get("joints", [])) == 26, "--stdin: 26 OpenXR joints")
        check(len(sequences) >= 5 and sequences[-1] > sequences[0], f"--stdin: the pose sequence grows as rows arrive ({sequences[:3]}...)")
        check(state.get("skipped") == 1 and state.get("lines") == frames * rows + 1, f"--stdin: the line that is not a row is counted ({state.get('skipped')} of {state.get('lines')})")
        check(str(state.get("first_skipped", "")).startswith("line 1: 1 field, expected 3 (row,value,timestamp"),
              f"--stdin: the page is told why ({state.get('first_skipped')!r})")
    finally:
        server.terminate()
        server.wait(timeout=10)


def page_status(url: str) -> str:
    dom = subprocess.run([CHROMIUM, *CHROMIUM_FLAGS, "--dump-dom", url], capture_output=True, text=True, timeout=60).stdout
    match = re.search(r'<pre id="status">([^<]*)</pre>', dom)
    return match.group(1) if match else ""


def main() -> int:
    if not CLI.exists():
        print(f"FAILED: the tool {CLI} does not exist (build it, or set GLOVEPOSE_CLI)")
        return 1
    if CHROMIUM is None:
        print("FAILED: chromium is not installed (tools/setup.sh installs Debian's chromium)")
        return 1
    work = Path(tempfile.mkdtemp(prefix="glovepose_view_"))
    recording = work / "recording.safetensors"
    subprocess.run([str(CLI), "simulate", "--seed", "2026", "--subjects", "1", "--sessions", "1", "--gloves", "1", "--minutes", "0.5",
                    "--calibration-seconds", "2", "--raw-rows", "--out", str(recording)], check=True, capture_output=True)
    server = subprocess.Popen([str(CLI), "view", "--port", "0", "--seconds", "40", "--replay", str(recording)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
        check(match is not None, f"the tool prints its address (got {line!r})")
        if match is None:
            return 1
        port = int(match.group(1))
        url = f"http://127.0.0.1:{port}/"

        # (a) the state, once the 2 s calibration has passed
        state = {}
        for _ in range(100):
            state = json.loads(urllib.request.urlopen(url + "state", timeout=5).read())
            if state.get("active"):
                break
            time.sleep(0.1)
        check(state.get("active") is True, "a pose arrives after the calibration")
        check(len(state.get("joints", [])) == 26 and all(len(j) == 3 for j in state["joints"]), "26 OpenXR joints of 3 coordinates")
        check(len(state.get("angles", [])) == 25 and len(state.get("dof_names", [])) == 25, "25 angles with their names")
        check(state.get("joints", [[1]])[1] == [0.0, 0.0, 0.0], "the wrist joint is the origin")
        check("trusted" in state and "flag_names" in state and "compute_us" in state and "oldest_age_ms" in state,
              "trust flags and latency figures")

        # (b) a hand is drawn: orange pixels in the canvas (the left 640 x 560)
        shot = work / "view.png"
        subprocess.run([CHROMIUM, *CHROMIUM_FLAGS, f"--screenshot={shot}", url], capture_output=True, timeout=60)
        check(shot.exists(), "chromium wrote a screenshot")
        if shot.exists():
            width, height, channels, rows = png_pixels(shot)
            orange = 0
            for y in range(min(height, 560)):
                row = rows[y]
                for x in range(min(width, 640)):
                    r, g, b = row[x * channels], row[x * channels + 1], row[x * channels + 2]
                    if r > 200 and 100 < g < 190 and b < 90:
                        orange += 1
            print(f"screenshot {width}x{height}: {orange} pixels of the hand's colour")
            check(orange > 400, "the hand is drawn in the canvas")

        # (c) the page's own state follows the stream
        first = page_status(url)
        time.sleep(1.0)
        second = page_status(url)
        print(f"page status: {first!r} then {second!r}")
        parse = re.compile(r"frames (\d+) seq (\d+) webgl (\w+) tip (\S+)")
        a, b = parse.search(first), parse.search(second)
        check(a is not None and b is not None, "the page shows frames, pose sequence and fingertip")
        if a and b:
            check(a.group(3) == "true", "WebGL is on")
            check(int(a.group(1)) >= 2 and int(b.group(1)) >= 2, "the page receives the hand repeatedly")
            check(int(b.group(2)) > int(a.group(2)), "the pose sequence grows: the page follows the stream")
            check(a.group(4) != b.group(4), "the fingertip moved between the two looks")

        # (d) loopback only: the port is not open on the machine's other addresses
        try:
            others = [address for address in socket.gethostbyname_ex(socket.gethostname())[2] if not address.startswith("127.")]
        except OSError:  # no name for this host: nothing else to try
            others = []
        for address in others:
            with socket.socket() as probe:
                probe.settimeout(1.0)
                check(probe.connect_ex((address, port)) != 0, f"not reachable on {address}")
    finally:
        server.terminate()
        server.wait(timeout=10)
    try:
        check_stdin(recording)  # (e)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{passed} passed, {failed} failed")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
