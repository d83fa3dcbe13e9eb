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
import subprocess
import sys
import time
from pathlib import Path
from typing import List

sys.path.insert(0, str(Path(__file__).resolve().parent))
from runner import Skip, Suite  # noqa: E402
from glove_device import PtyPort, free_port, play, run_with_options  # noqa: E402
from wire_doc import Frame, decode  # noqa: E402

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
    port = PtyPort(suite.tmp / "glove-port")
    out = suite.tmp / "pty.gpw"
    rec = record(str(port.name), out)
    time.sleep(0.3)
    unsent = play(frames, port.send, port.reopen, OPTIONS.reopen, random.Random(3), OPTIONS.speed)
    err = stop(rec)
    port.close()
    check_recording(out, frames, err, OPTIONS.reopen + 1, unsent)


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
    unsent = play(frames, device.send, device.reconnect, OPTIONS.reopen, random.Random(4), OPTIONS.speed)
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
                  lambda: None, 0, rng, OPTIONS.speed)
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
    play(frames[:200], device.send, device.reconnect, 1, random.Random(6), OPTIONS.speed, changed_serial=True)
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
    sys.exit(run_with_options(suite, OPTIONS, "reopenings of each link"))
