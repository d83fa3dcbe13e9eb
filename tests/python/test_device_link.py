"""A glove's link that goes away and comes back: a pty closed and reopened, a TCP connection dropped,
datagrams lost. The device here is this test: it sends the frames of a simulated glove (decoded with
wire_doc.py, written from docs/wire_protocol.md) as a real one would, with a Hello after every
connection that goes on with its sequence, and `glovepose record` reads them through the link:
- every frame in the recording is one the device sent, byte for byte, in order;
- the frames it lost (sent while the link was down, or cut off with it) are exactly the recording's
  sequence gaps, as record counts them;
- the link was reopened each time, with no frame before a connection's Hello used;
- a Hello that names another glove after a reconnection stops the recording with an error, and a
  port that does not exist is an error at once.

    GLOVEPOSE_CLI=build/tools/glovepose /usr/bin/python3 tests/python/test_device_link.py
    ... test_device_link.py --minutes 10 --reopen 20    (the long run: a 10-minute take, 20 reopenings)"""

from __future__ import annotations

import argparse
import os
import random
import re
import signal
import socket
import struct
import subprocess
import sys
import time
import tty
from pathlib import Path
from typing import Callable, List

sys.path.insert(0, str(Path(__file__).resolve().parent))
from runner import Skip, Suite  # noqa: E402
from wire_doc import Frame, decode, encode  # noqa: E402

CLI = os.environ.get("GLOVEPOSE_CLI", "")
suite = Suite("glovepose_link_")
OPTIONS = argparse.Namespace(minutes=0.25, reopen=4, speed=4.0)


def setup_checks():
    if not CLI:
        raise Skip("GLOVEPOSE_CLI is not set")


_frames: List[Frame] = []


def glove_frames() -> List[Frame]:
    """A simulated glove's Hello and cells frames (its readings at 60 Hz)."""
    if not _frames:
        path = suite.tmp / "glove.gpw"
        result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", str(OPTIONS.minutes), "--gloves", "1",
                                 "--calibration-seconds", "0", "--seed", "8", "--threads", "1", "--stream", str(path), "--stream-payload",
                                 "cells", "--speed", "0", "--serial", "77"], capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        _frames.extend(decode(path.read_bytes()))
        assert _frames[0].kind == 1 and all(f.kind == 4 for f in _frames[1:])
    return _frames


def with_serial(hello: Frame, sequence: int, device_us: int, serial: int | None = None) -> bytes:
    """The device's Hello for a new connection: its next sequence number and the time now."""
    payload = hello.payload if serial is None else struct.pack("<I", serial) + hello.payload[4:]
    return encode(1, sequence, device_us, payload)


def play(frames: List[Frame], send: Callable[[bytes], None], reconnect: Callable[[], None], reopenings: int, rng: random.Random,
         changed_serial: bool = False) -> List[int]:
    """Sends the frames at OPTIONS.speed times real time; at `reopenings` random moments the link is
    closed and opened again (`reconnect`), the frames of 0.05-0.4 s of device time meanwhile never
    sent, and the first of those replaced by a Hello, as a device that goes on counting would send
    on its new connection. Returns the sequences never sent."""
    readings = frames[1:]
    moments = sorted(rng.sample(range(30, len(readings) - 30), reopenings))
    unsent: List[int] = []
    start = time.monotonic()
    first_us = readings[0].device_us
    i = 0
    send(encode(1, frames[0].sequence, frames[0].device_us, frames[0].payload))
    while i < len(readings):
        due = start + (readings[i].device_us - first_us) * 1e-6 / OPTIONS.speed
        wait = due - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        if moments and i >= moments[0]:
            moments.pop(0)
            reconnect()
            skip = max(1, int(rng.uniform(0.05, 0.4) * 60))
            gone = readings[i:i + skip]
            unsent.extend(f.sequence for f in gone[1:])
            i += len(gone)
            start -= len(gone) / 60 / OPTIONS.speed  # the device did not wait while the link was down
            send(with_serial(frames[0], gone[0].sequence, gone[0].device_us, 78 if changed_serial else None))
            continue
        send(encode(4, readings[i].sequence, readings[i].device_us, readings[i].payload))
        i += 1
    return unsent


def record(source: str, out: Path) -> subprocess.Popen:
    return subprocess.Popen([CLI, "record", "--in", source, "--out", str(out)], stderr=subprocess.PIPE, text=True)


def stop(rec: subprocess.Popen) -> str:
    time.sleep(0.5)  # the last frames reach the recording
    rec.send_signal(signal.SIGINT)
    _, err = rec.communicate(timeout=30)
    assert rec.returncode == 0, err
    return err


def check_recording(path: Path, frames: List[Frame], err: str, opened: int, unsent: List[int]) -> None:
    """Every recorded frame was sent as it is; the gaps, among them every frame never sent, are what
    record counted as lost."""
    sent = {f.sequence: f.payload for f in frames}
    kept = decode(path.read_bytes())
    sequences = [f.sequence for f in kept]
    assert sequences == sorted(set(sequences)), "frames out of order or repeated"
    readings = [f for f in kept if f.kind == 4]
    assert all(sent.get(f.sequence) == f.payload for f in readings), "a recorded reading differs from the one sent"
    gaps = sum(b - a - 1 for a, b in zip(sequences, sequences[1:]))
    assert not set(unsent) & set(sequences), "a frame never sent is in the recording"
    assert set(unsent) <= set(range(sequences[0], sequences[-1])), "the frames never sent are not all within the recording's span"
    summary = next(line for line in err.splitlines() if "; link: " in line)
    lost = int(re.search(r"(\d+) lost", summary).group(1))
    assert lost == gaps, f"record counted {lost} lost, the recording has {gaps} missing: {summary}"
    times = int(re.search(r"opened (\d+) time", summary).group(1))
    assert times == opened, f"the link was opened {times} times, expected {opened}: {summary}"
    assert re.search(r" 0 frames dropped before a Hello", summary), summary
    print(f"  {len(readings)} readings recorded, {lost} lost and counted ({len(unsent)} never sent, {lost - len(unsent)} cut off with"
          f" the link), link opened {times} times")


@suite.test
def a_pty_closed_and_reopened_loses_only_what_it_did_not_carry():
    setup_checks()
    frames = glove_frames()
    link = suite.tmp / "glove-port"  # a stable name, as udev gives a glove (socat's link= likewise)
    state = {}

    def open_pty():
        master, slave = os.openpty()
        tty.setraw(slave)  # as a serial port's driver is: no byte is translated before the reader opens it
        staged = suite.tmp / "glove-port.new"
        staged.unlink(missing_ok=True)
        staged.symlink_to(os.ttyname(slave))
        os.replace(staged, link)
        state["master"], state["slave"] = master, slave

    def reconnect():
        os.close(state["master"])  # the reader's side hangs up
        os.close(state["slave"])
        time.sleep(0.02)
        open_pty()

    open_pty()
    out = suite.tmp / "pty.gpw"
    rec = record(str(link), out)
    time.sleep(0.3)
    unsent = play(frames, lambda b: os.write(state["master"], b), reconnect, OPTIONS.reopen, random.Random(3))
    err = stop(rec)
    os.close(state["master"])
    os.close(state["slave"])
    check_recording(out, frames, err, OPTIONS.reopen + 1, unsent)



def free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class TcpDevice:
    """A device that serves its stream over TCP to the reader that connects: `glovepose record`."""

    def __init__(self, out: Path, reader_may_leave: bool = False):
        port = free_port(socket.SOCK_STREAM)
        self.server = socket.create_server(("127.0.0.1", port))
        self.rec = record(f"tcp:127.0.0.1:{port}", out)
        self.connection = self.server.accept()[0]
        self.reader_may_leave = reader_may_leave

    def send(self, b: bytes):
        try:
            self.connection.sendall(b)
        except OSError:
            if not self.reader_may_leave:
                raise

    def reconnect(self):
        self.connection.close()  # the device drops the connection; the reader connects again
        self.connection = self.server.accept()[0]

    def close(self):
        self.connection.close()
        self.server.close()


@suite.test
def a_tcp_device_dropped_and_reconnected():
    setup_checks()
    frames = glove_frames()
    out = suite.tmp / "tcp.gpw"
    device = TcpDevice(out)
    unsent = play(frames, device.send, device.reconnect, OPTIONS.reopen, random.Random(4))
    err = stop(device.rec)
    device.close()
    check_recording(out, frames, err, OPTIONS.reopen + 1, unsent)


@suite.test
def udp_datagrams_lost_on_the_way_are_counted():
    setup_checks()
    frames = glove_frames()
    port = free_port(socket.SOCK_DGRAM)
    out = suite.tmp / "udp.gpw"
    rec = record(f"udp:127.0.0.1:{port}", out)
    time.sleep(0.3)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rng = random.Random(5)
    # one datagram per frame, 1 in 20 never sent: a datagram link has no connection to lose
    unsent = play(frames, lambda b: None if (b[3] == 4 and rng.random() < 0.05) else sender.sendto(b, ("127.0.0.1", port)),
                  lambda: None, 0, rng)
    err = stop(rec)
    sender.close()
    kept = {f.sequence for f in decode(out.read_bytes())}
    dropped = [f.sequence for f in frames[1:] if f.sequence not in kept]
    assert dropped, "no datagram was left out"
    check_recording(out, frames, err, 1, dropped)


@suite.test
def the_simulator_streams_datagrams_with_a_hello_every_second():
    setup_checks()
    port = free_port(socket.SOCK_DGRAM)
    out = suite.tmp / "simulated-udp.gpw"
    rec = record(f"udp:127.0.0.1:{port}", out)
    time.sleep(0.3)
    result = subprocess.run([CLI, "simulate", "--subjects", "1", "--sessions", "1", "--minutes", str(5 / 60), "--gloves", "1",
                             "--calibration-seconds", "0", "--seed", "8", "--threads", "1", "--stream", f"udp:127.0.0.1:{port}",
                             "--stream-payload", "cells", "--speed", "4", "--serial", "77"], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    err = stop(rec)
    kept = decode(out.read_bytes())
    hellos = [f.device_us for f in kept if f.kind == 1]
    assert len(hellos) == 6 and hellos[0] == 0 and all(0.99e6 <= b - a <= 1.02e6 for a, b in zip(hellos, hellos[1:])), hellos
    assert len(kept) - len(hellos) == 300, f"{len(kept) - len(hellos)} readings of 5 s at 60 Hz"
    check_recording(out, kept, err, 1, [])


@suite.test
def another_glove_after_a_reconnection_is_an_error():
    setup_checks()
    frames = glove_frames()
    out = suite.tmp / "swapped.gpw"
    device = TcpDevice(out, reader_may_leave=True)
    play(frames[:200], device.send, device.reconnect, 1, random.Random(6), changed_serial=True)
    _, err = device.rec.communicate(timeout=30)
    device.close()
    assert device.rec.returncode != 0, err
    assert "serial 78" in err and "serial 77" in err, err
    kept = decode(out.read_bytes())
    assert kept and all(f.kind == 4 for f in kept[1:]), "the recording before the other glove is kept"


@suite.test
def a_port_that_is_not_there_is_an_error_at_once():
    setup_checks()
    for source, says in (("serial:/dev/glovepose-no-such-port", "cannot open it"), ("tcp:127.0.0.1:1", "cannot open it"),
                         ("udp:127.0.0.1:99999", "port '99999'"), ("serial:@9600", "no port")):
        result = subprocess.run([CLI, "record", "--in", source, "--out", str(suite.tmp / "never.gpw")], capture_output=True, text=True,
                                timeout=30)
        assert result.returncode != 0 and says in result.stderr, (source, result.stderr)
        assert not (suite.tmp / "never.gpw").exists()


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--minutes", type=float, default=OPTIONS.minutes, help="the simulated take's length")
    parser.add_argument("--reopen", type=int, default=OPTIONS.reopen, help="reopenings of each link")
    parser.add_argument("--speed", type=float, default=OPTIONS.speed, help="times real time")
    OPTIONS = parser.parse_args()
    sys.exit(suite.run())
