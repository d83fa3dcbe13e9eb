"""A glove as the tests' device: it sends a simulated glove's frames (wire_doc.py) in real time or
faster over a link that it closes and opens again at random moments, as a device that is unplugged
and plugged in again does: a Hello on each new connection that goes on counting, and the frames of
the time in between never sent."""

from __future__ import annotations

import argparse
import os
import random
import socket
import struct
import time
import tty
from pathlib import Path
from typing import Callable, List

from wire_doc import Frame, encode


def with_serial(hello: Frame, sequence: int, device_us: int, serial: int | None = None) -> bytes:
    """The device's Hello for a new connection: its next sequence number and the time now."""
    payload = hello.payload if serial is None else struct.pack("<I", serial) + hello.payload[4:]
    return encode(1, sequence, device_us, payload)


def play(frames: List[Frame], send: Callable[[bytes], None], reconnect: Callable[[], None], reopenings: int, rng: random.Random,
         speed: float, changed_serial: bool = False, reconnected: Callable[[], None] = lambda: None) -> List[int]:
    """Sends the frames at `speed` times real time; at `reopenings` random moments the link is
    closed and opened again (`reconnect`), the frames of 0.05-0.4 s of device time meanwhile never
    sent, and the first of those replaced by a Hello, as a device that goes on counting would send
    on its new connection (`reconnected` is called once it is sent). Returns the sequences never
    sent."""
    readings = frames[1:]
    # At least 1.5 s of readings apart: two reopenings closer than the reader's retry would look like one.
    slots = range(30, len(readings) - 120, 90)
    moments = sorted(m + rng.randrange(0, 60) for m in rng.sample(slots, reopenings))
    unsent: List[int] = []
    start = time.monotonic()
    first_us = readings[0].device_us
    i = 0
    send(encode(1, frames[0].sequence, frames[0].device_us, frames[0].payload))
    while i < len(readings):
        due = start + (readings[i].device_us - first_us) * 1e-6 / speed
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
            start -= len(gone) / 60 / speed  # the device did not wait while the link was down
            send(with_serial(frames[0], gone[0].sequence, gone[0].device_us, 78 if changed_serial else None))
            reconnected()
            continue
        send(encode(4, readings[i].sequence, readings[i].device_us, readings[i].payload))
        i += 1
    return unsent


class PtyPort:
    """A pty under a stable name (as udev's or socat's links are): the device writes its side; the
    reader opens the name; reopen() closes it (the reader's side hangs up) and makes a new one."""

    def __init__(self, name: Path):
        self.name = name
        self.open()

    def open(self):
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # as a serial port's driver is: no byte is translated before the reader opens it
        staged = self.name.with_name(self.name.name + ".new")
        staged.unlink(missing_ok=True)
        staged.symlink_to(os.ttyname(self.slave))
        os.replace(staged, self.name)

    def send(self, data: bytes):
        os.write(self.master, data)

    def reopen(self):
        self.close()
        time.sleep(0.02)
        self.open()

    def close(self):
        os.close(self.master)
        os.close(self.slave)


def free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run_with_options(suite, options: argparse.Namespace, reopen_help: str) -> int:
    """Runs `suite` with `options` (minutes, reopen, speed) as the command line sets them."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--minutes", type=float, default=options.minutes, help="the simulated take's length")
    parser.add_argument("--reopen", type=int, default=options.reopen, help=reopen_help)
    parser.add_argument("--speed", type=float, default=options.speed, help="times real time")
    vars(options).update(vars(parser.parse_args()))
    return suite.run()
