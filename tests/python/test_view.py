#!/usr/bin/env python3
"""`glovepose view` in a real browser: headless Chromium (Debian's `chromium`) opens the page.

A recording with raw rows and true angles (a 2 s calibration, then a session) is written with
`glovepose simulate` and replayed by `glovepose view --port 0 --replay FILE` in real time. The test
drives Chromium through its DevTools protocol on a pipe (--remote-debugging-pipe: JSON messages,
no library), in real time (the page's event stream never ends, which stalls Chromium's virtual time).
(a) /state (JSON): a pose with 26 joints, 25 angles in degrees, the truth's joints, the maps;
(b) a screenshot of the page: the 3D area holds a shaded hand surface: many pixels off the
    background with a wide spread of brightness (spheres and capsules lit from a side), not lines;
    the PNG is decoded here with zlib (no imaging library);
(c) the heat maps follow the stream: two screenshots of the map area a second apart differ, and the
    page's frame count and pose sequence grow;
(d) truth and estimate overlap: screenshots of the 3D area with only the estimate and with only the
    truth shown (the page paused on one state): their pixel masks overlap (intersection over union);
    the page's projected palm joints coincide (both hands drawn at the subject's size, one frame);
(e) the server: a malformed request line (400), an unknown path (404), a POST (405), a request head
    sent too slowly (408) and one too long (431) are each answered with their status, while a
    client of the event stream (GET /events) keeps receiving events at about 30 Hz;
(f) the server listens on the loopback address only;
(g) the same recording's first 10 s of rows as text lines on stdin to `glovepose view --stdin
    --calibration-seconds 2` (a real glove's path), paced at twice real time, after a line that is
    not a row: the hand is first calibrating, then posed, and its pose sequence grows while rows
    arrive; /state counts the skipped line and says why.

Run: /usr/bin/python3 tests/python/test_view.py   (GLOVEPOSE_CLI: the tool, default
build/tools/glovepose; GLOVEPOSE_VIEW_SHOT=FILE also saves the page's screenshot there). Exit code 0
when every check passes; the last line reads 'N passed, N failed'.
"""

from __future__ import annotations

import base64
import json
import os
import re
import shutil
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CLI = Path(os.environ.get("GLOVEPOSE_CLI", ROOT / "build" / "tools" / "glovepose"))
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
WIDTH, HEIGHT = 1280, 860
SCENE = (0, 0, 620, 600)  # the 3D canvas: x, y, width, height (view.html)
BACKGROUND = (0x15, 0x17, 0x1C)

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


class Browser:
    """Headless Chromium driven over --remote-debugging-pipe (fd 3: commands in, fd 4: answers out,
    each a JSON message ending in a NUL byte): one page, its session, commands answered in order."""

    def __init__(self) -> None:
        to_browser_r, self.to_browser = os.pipe()
        self.from_browser, from_browser_w = os.pipe()

        def fds() -> None:  # in the child: the pipe ends where Chromium looks for them
            os.dup2(to_browser_r, 3)
            os.dup2(from_browser_w, 4)

        self.process = subprocess.Popen(
            [CHROMIUM, "--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
             f"--window-size={WIDTH},{HEIGHT}", "--remote-debugging-pipe", "--no-first-run", "--user-data-dir=" + tempfile.mkdtemp(),
             "about:blank"], preexec_fn=fds, close_fds=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.buffer, self.next_id, self.session = b"", 0, None
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        self.call("Page.enable")
        self.call("Emulation.setDeviceMetricsOverride", {"width": WIDTH, "height": HEIGHT, "deviceScaleFactor": 1, "mobile": False})

    def call(self, method: str, params: dict | None = None, timeout: float = 30.0) -> dict:
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if self.session and not method.startswith("Target."):
            message["sessionId"] = self.session
        os.write(self.to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            while b"\0" in self.buffer:
                raw, self.buffer = self.buffer.split(b"\0", 1)
                answer = json.loads(raw)
                if answer.get("id") == self.next_id:
                    if "error" in answer:
                        raise RuntimeError(f"{method}: {answer['error']}")
                    return answer.get("result", {})
            chunk = os.read(self.from_browser, 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed its pipe")
            self.buffer += chunk
        raise RuntimeError(f"{method}: no answer within {timeout} s")

    def evaluate(self, expression: str):
        return self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True})["result"].get("value")

    def screenshot(self, path: Path, clip: tuple[int, int, int, int] | None = None) -> None:
        params: dict = {"format": "png"}
        if clip:
            params["clip"] = {"x": clip[0], "y": clip[1], "width": clip[2], "height": clip[3], "scale": 1}
        path.write_bytes(base64.b64decode(self.call("Page.captureScreenshot", params)["data"]))

    def close(self) -> None:
        try:
            self.call("Browser.close", timeout=5)
        except (RuntimeError, OSError):
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
        os.close(self.to_browser)
        os.close(self.from_browser)


def off_background(path: Path, box: tuple[int, int, int, int]):
    """The pixels of `box` (x, y, w, h) that differ from the page's background: a set of (x, y)
    and their brightness values (0..765)."""
    width, height, channels, rows = png_pixels(path)
    x0, y0, w, h = box
    mask, brightness = set(), []
    for y in range(y0, min(height, y0 + h)):
        row = rows[y]
        for x in range(x0, min(width, x0 + w)):
            r, g, b = row[x * channels], row[x * channels + 1], row[x * channels + 2]
            if abs(r - BACKGROUND[0]) + abs(g - BACKGROUND[1]) + abs(b - BACKGROUND[2]) > 24:
                mask.add((x, y))
                brightness.append(r + g + b)
    return mask, brightness


def raw_request(port: int, data: bytes) -> tuple[int, float]:
    """Sends `data` and returns the status the server answered with (0: none) and the seconds it
    took."""
    start = time.monotonic()
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        try:
            s.sendall(data)
        except OSError:  # the server answered and closed before all was sent
            pass
        answer = b""
        try:
            while b"\r\n" not in answer:
                more = s.recv(4096)
                if not more:
                    break
                answer += more
        except OSError:
            pass
    match = re.match(rb"HTTP/1\.1 (\d{3}) ", answer)
    return (int(match.group(1)) if match else 0), time.monotonic() - start


class EventListener(threading.Thread):
    """A client of GET /events counting the state events it receives, with their arrival times."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.port, self.times, self.stop, self.meta = port, [], False, None

    def run(self) -> None:
        with socket.create_connection(("127.0.0.1", self.port), timeout=5) as s:
            s.sendall(b"GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
            buffer = b""
            while not self.stop:
                try:
                    more = s.recv(65536)
                except socket.timeout:
                    continue
                if not more:
                    break
                buffer += more
                while b"\n\n" in buffer:
                    event, buffer = buffer.split(b"\n\n", 1)
                    if event.startswith(b"HTTP/1.1 200"):
                        event = event.split(b"\r\n\r\n", 1)[1]
                    if event.startswith(b"event: meta"):
                        self.meta = json.loads(event.split(b"data: ", 1)[1])
                    elif event.startswith(b"data: "):
                        self.times.append(time.monotonic())

    def count_between(self, begin: float, end: float) -> int:
        return sum(1 for t in self.times if begin <= t <= end)


def check_server(port: int) -> None:
    listener = EventListener(port)
    listener.start()
    time.sleep(0.5)
    begin = time.monotonic()
    results = {}

    def probe(name: str, *args) -> None:
        results[name] = raw_request(port, *args)

    probes = [
        threading.Thread(target=probe, args=("malformed", b"GARBAGE\r\n\r\n")),
        threading.Thread(target=probe, args=("unknown path", b"GET /nothing-here HTTP/1.1\r\nHost: x\r\n\r\n")),
        threading.Thread(target=probe, args=("post", b"POST /state HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n\r\n{}")),
        threading.Thread(target=probe, args=("slow", b"GET /state HTTP/1.1\r\nHost: x\r\n")),  # the head never ends
        threading.Thread(target=probe, args=("oversized", b"GET /state HTTP/1.1\r\nX-Filler: " + b"a" * 20000 + b"\r\n\r\n")),
    ]
    for p in probes:
        p.start()
    for p in probes:
        p.join(timeout=15)
    end = time.monotonic()
    time.sleep(0.2)
    listener.stop = True
    listener.join(timeout=5)
    expected = {"malformed": 400, "unknown path": 404, "post": 405, "slow": 408, "oversized": 431}
    for name, status in expected.items():
        got, seconds = results.get(name, (0, 0.0))
        print(f"server: {name} request answered {got} after {seconds:.2f} s")
        check(got == status, f"server: a {name} request is answered {status} (got {got})")
    check(1.5 <= results.get("slow", (0, 0.0))[1] <= 3.0, "server: the slow request is cut off at its time-out (2 s)")
    events = listener.count_between(begin, end)
    rate = events / (end - begin)
    print(f"server: {events} events in {end - begin:.2f} s meanwhile ({rate:.1f} per second)")
    check(rate >= 20.0, f"server: the event stream keeps going meanwhile, about 30 per second (got {rate:.1f})")
    check(listener.meta is not None and len(listener.meta.get("radii_mm", [])) == 26, "server: the stream starts with the hand's geometry")


def check_page(url: str, work: Path) -> None:
    browser = Browser()
    try:
        browser.call("Page.navigate", {"url": url})
        for _ in range(100):  # the page receives poses (the 2 s calibration has passed)
            if (browser.evaluate("viewer.seq") or -1) > 0 and browser.evaluate("viewer.drawn") > 2:
                break
            time.sleep(0.1)
        time.sleep(0.3)
        check(browser.evaluate("viewer.webgl") is True, "WebGL is on")

        # (b) a shaded hand surface in the 3D area
        shot = work / "view.png"
        browser.screenshot(shot)
        if os.environ.get("GLOVEPOSE_VIEW_SHOT"):
            shutil.copy(shot, os.environ["GLOVEPOSE_VIEW_SHOT"])
        mask, brightness = off_background(shot, SCENE)
        levels = len({b // 8 for b in brightness})
        mean = sum(brightness) / max(1, len(brightness))
        spread = (sum((b - mean) ** 2 for b in brightness) / max(1, len(brightness))) ** 0.5
        print(f"scene: {len(mask)} of {SCENE[2] * SCENE[3]} pixels off the background, {levels} brightness levels, spread {spread:.0f}")
        check(len(mask) > 20000, "a hand surface fills the 3D area (more than 20000 pixels), not lines")
        check(levels >= 40 and spread >= 30, "the surface is shaded (many brightness levels)")

        # (c) the maps and the page follow the stream
        maps_box = (634, 150, 600, 180)
        first_state = browser.evaluate("JSON.stringify([viewer.frames, viewer.seq])")
        looked = time.monotonic()
        first, second = work / "maps1.png", work / "maps2.png"
        browser.screenshot(first, maps_box)
        time.sleep(1.0)
        browser.screenshot(second, maps_box)
        second_state = browser.evaluate("JSON.stringify([viewer.frames, viewer.seq])")
        looked = time.monotonic() - looked
        _, _, ch, rows1 = png_pixels(first)
        _, _, _, rows2 = png_pixels(second)
        changed = sum(1 for a, b in zip(rows1, rows2) for i in range(0, len(a), ch) if a[i:i + 3] != b[i:i + 3])
        print(f"maps: {changed} of {maps_box[2] * maps_box[3]} pixels changed; page (frames, seq) {first_state} then {second_state}, "
              f"{looked:.2f} s apart")
        check(changed > 2000, "the heat maps change with the stream")
        (f1, s1), (f2, s2) = json.loads(first_state), json.loads(second_state)
        check(f2 - f1 >= 20 * looked, f"the page keeps receiving, about 30 events per second ({(f2 - f1) / looked:.1f})")
        check(s2 > s1, "the pose sequence grows: the page follows the stream")

        # (d) truth and estimate overlap: one state, each hand alone
        browser.evaluate("viewer.paused = true")
        time.sleep(0.2)
        report = json.loads(browser.evaluate("document.getElementById('status').textContent"))
        masks = {}
        for name in ("estimate", "truth"):
            browser.evaluate(f"viewer.only('{name}')")
            time.sleep(0.2)
            path = work / f"{name}.png"
            browser.screenshot(path, SCENE)
            masks[name], _ = off_background(path, (0, 0, SCENE[2], SCENE[3]))
        browser.evaluate("viewer.only(null); viewer.paused = false")
        both, either = len(masks["estimate"] & masks["truth"]), len(masks["estimate"] | masks["truth"])
        iou = both / max(1, either)
        print(f"overlap: estimate {len(masks['estimate'])} px, truth {len(masks['truth'])} px, both {both}, intersection over union {iou:.2f}")
        check(len(masks["truth"]) > 10000, "the truth is drawn as a hand too")
        check(iou > 0.5, f"truth and estimate overlap (intersection over union {iou:.2f} > 0.5)")
        estimate_px, truth_px = report.get("estimate_px"), report.get("truth_px")
        check(estimate_px is not None and truth_px is not None, "the page reports both hands' projected joints")
        if estimate_px and truth_px:
            palm = [0, 1, 6, 7, 11, 12, 16, 17, 21, 22]  # no DoF moves these: they coincide when both hands are one size in one frame
            check(all(abs(estimate_px[j][0] - truth_px[j][0]) <= 1 and abs(estimate_px[j][1] - truth_px[j][1]) <= 1 for j in palm),
                  "the two hands' palms coincide on the screen")
    finally:
        browser.close()
def check_stdin(recording: Path) -> None:
    frames, rows, raw, timestamps = read_rows(recording)
    frames = min(frames, 600)  # 10 s: the 2 s calibration, then poses
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
    started = time.monotonic()
    server = subprocess.Popen([str(CLI), "view", "--port", "0", "--seconds", "40", "--replay", str(recording)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    try:
        line = server.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
        print(f"the address after {time.monotonic() - started:.2f} s: {line.strip()}")
        check(match is not None, f"the tool prints its address (got {line!r})")
        if match is None:
            return 1
        check(time.monotonic() - started < 3.0, "the address is printed at once")
        port = int(match.group(1))
        url = f"http://127.0.0.1:{port}/"

        # (a) the state, once the 2 s calibration has passed
        state = {}
        for _ in range(100):
            state = get_state(url)
            if state.get("active"):
                break
            time.sleep(0.1)
        check(state.get("active") is True, "a pose arrives after the calibration")
        check(len(state.get("joints", [])) == 26 and all(len(j) == 3 for j in state["joints"]), "26 OpenXR joints of 3 coordinates")
        check(state.get("joints", [[1]])[1] == [0.0, 0.0, 0.0], "the wrist joint is the origin")
        check(len(state.get("angles_deg", [])) == 25 and len(state.get("truth_deg") or []) == 25, "25 angles in degrees, and the truth's")
        check(len(state.get("confidence", [])) == 25 and all(0.0 <= c <= 1.0 for c in state["confidence"]), "25 confidences in [0, 1]")
        check(len(state.get("truth_joints") or []) == 26, "the truth's joints (a simulated recording)")
        check(len(state.get("stretch", [])) == 2 and len(state.get("pose_map", [])) == 5, "two stretch maps and the pose map")
        check(len(state.get("pinch", [])) == 4 and all(0.0 <= p["strength"] <= 1.0 for p in state.get("pinch", [])),
              "pinch strengths of the four fingers in [0, 1]")
        check("trusted" in state and "flag_names" in state and "compute_us" in state and "oldest_age_ms" in state,
              "trust flags and latency figures")
        sizes = {name: len(urllib.request.urlopen(url + name, timeout=5).read()) for name in ("", "view.js", "three.module.min.js",
                                                                                               "OrbitControls.js")}
        print(f"page: {sum(sizes.values())} bytes ({sizes})")

        check_page(url, work)  # (b), (c), (d)
        check_server(port)  # (e)

        # (f) loopback only: the port is not open on the machine's other addresses
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
        check_stdin(recording)  # (g)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{passed} passed, {failed} failed")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
