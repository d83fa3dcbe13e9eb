#!/usr/bin/env python3
"""`glovepose view`'s server under load: 200 connections to its event stream at once, 50 of them
stalled (a reader that asked for events and never reads, with the smallest receive buffer), while
a recording is replayed in real time. Every one of the other 150 must keep receiving at least 29
state events per second over a 6 s window (the server's pace is 30 per second); the server's
resident memory and threads are reported, its memory growth bounded (below 64 MiB over the idle
server), and the stalled connections are dropped by the server's send time-out (2 s) once their
buffers are full (within 40 s), not kept.

Run: GLOVEPOSE_CLI=build/tools/glovepose /usr/bin/python3 tests/python/test_view_load.py"""

from __future__ import annotations

import os
import re
import selectors
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CLI = os.environ.get("GLOVEPOSE_CLI", str(ROOT / "build" / "tools" / "glovepose"))
READERS, STALLED, WINDOW, WARM_UP = 150, 50, 6.0, 2.0
DROP_WITHIN = 40.0  # s from the stalled readers' request to their drop: buffers of a few MB at the stream's rate, then 2 s
REQUEST = b"GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"


def status_of(pid: int) -> dict:
    fields = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, value = line.partition(":")
        fields[key] = value.strip()
    return fields


def kib(value: str) -> int:
    return int(value.split()[0])


def main() -> int:
    failures = []
    t0 = time.monotonic()

    def mark(what: str) -> None:
        print(f"  [{time.monotonic() - t0:5.1f} s] {what}", flush=True)

    with tempfile.TemporaryDirectory(prefix="glovepose_view_load_") as tmp:
        recording = Path(tmp) / "recording.safetensors"
        subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", "1", "--gloves", "1", "--calibration-seconds", "2",
                        "--raw-rows", "--seed", "3", "--out", str(recording)], check=True, capture_output=True)
        server = subprocess.Popen([CLI, "view", "--port", "0", "--replay", str(recording), "--seconds", "70"], stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, text=True)
        try:
            line = server.stdout.readline()
            port = int(re.search(r"127\.0\.0\.1:(\d+)", line).group(1))
            deadline = time.monotonic() + 20
            while time.monotonic() < deadline:  # the replay's first pose
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/state", timeout=5) as answer:
                    if b'"published":0' not in answer.read().replace(b" ", b""):
                        break
                time.sleep(0.2)
            mark("first pose")
            idle = status_of(server.pid)
            stalled, stalled_since = [], time.monotonic()
            for _ in range(STALLED):
                s = socket.socket()
                s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1)  # the kernel's smallest
                s.connect(("127.0.0.1", port))
                s.sendall(REQUEST)
                stalled.append(s)
            selector = selectors.DefaultSelector()
            counts, tails = {}, {}
            for k in range(READERS):
                s = socket.create_connection(("127.0.0.1", port))
                s.sendall(REQUEST)
                s.setblocking(False)
                selector.register(s, selectors.EVENT_READ, k)
                counts[k], tails[k] = 0, b""
            start = time.monotonic()
            window_start, window_counts = None, None
            closed = set()
            while True:
                now = time.monotonic()
                if window_start is None and now - start >= WARM_UP:
                    window_start, window_counts = now, dict(counts)
                if window_start is not None and now - window_start >= WINDOW:
                    break
                for key, _ in selector.select(timeout=0.1):
                    try:
                        data = key.fileobj.recv(1 << 16)
                    except BlockingIOError:
                        continue
                    k = key.data
                    if not data:
                        closed.add(k)
                        selector.unregister(key.fileobj)
                        continue
                    joined = tails[k] + data
                    counts[k] += joined.count(b"\ndata: {") + (joined.startswith(b"data: {") and not tails[k])
                    tails[k] = joined[-7:]
            elapsed = time.monotonic() - window_start
            loaded = status_of(server.pid)
            rates = sorted((counts[k] - window_counts[k]) / elapsed for k in counts)
            print(f"readers: {READERS} (+{STALLED} stalled); events per second per reader over {elapsed:.1f} s: "
                  f"min {rates[0]:.1f}, median {rates[len(rates) // 2]:.1f}, max {rates[-1]:.1f}; closed early: {len(closed)}")
            print(f"server: resident {kib(idle['VmRSS']) / 1024:.1f} MiB idle, {kib(loaded['VmRSS']) / 1024:.1f} MiB loaded "
                  f"(peak {kib(loaded['VmHWM']) / 1024:.1f} MiB); threads {idle['Threads']} idle, {loaded['Threads']} loaded")
            if closed:
                failures.append(f"{len(closed)} readers were closed by the server")
            if rates[0] < 29.0:
                failures.append(f"the slowest reader got {rates[0]:.1f} events per second, expected at least 29")
            growth = kib(loaded["VmHWM"]) - kib(idle["VmRSS"])
            if growth > 64 * 1024:
                failures.append(f"the server's memory grew by {growth / 1024:.1f} MiB under load, expected less than 64")
            mark("window done")
            # The stalled readers: the server gives up on each once a send waited 2 s on its full buffer
            # (the kernel's buffers take a while to fill at the stream's rate), which ends that
            # connection's thread. The readers close now: what threads remain are the stalled ones'.
            for key in list(selector.get_map().values()):
                key.fileobj.close()
            deadline = stalled_since + DROP_WITHIN
            while True:
                after = status_of(server.pid)
                held = int(after["Threads"]) - int(idle["Threads"])
                if held <= 0 or time.monotonic() > deadline:
                    break
                time.sleep(0.5)
            mark("stalled checked")
            print(f"stalled readers held by the server {time.monotonic() - stalled_since:.1f} s after they stopped reading: {max(held, 0)} "
                  f"of {STALLED} (threads {loaded['Threads']} -> {after['Threads']}); resident {kib(after['VmRSS']) / 1024:.1f} MiB")
            if held > 0:
                failures.append(f"{held} stalled readers still held by the server {DROP_WITHIN:.0f} s after they stopped reading")
        finally:
            server.terminate()
            server.wait(timeout=30)
            mark("server ended")
    for f in failures:
        print(f"FAILED: {f}")
    print("PASS" if not failures else f"{len(failures)} failed")
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main())
