"""The wire protocol's frames as docs/wire_protocol.md lays them out, decoded and encoded with
Python's struct and zlib's CRC-32 from that page alone: the tests' independent reference, sharing no
code with the C++ encoder or parser."""

from __future__ import annotations

import struct
import zlib
from typing import List, NamedTuple


class Frame(NamedTuple):
    kind: int
    sequence: int
    device_us: int
    payload: bytes
    start: int  # byte offset in the stream
    end: int


def decode(stream: bytes, cut_tail: bool = False) -> List[Frame]:
    """Every frame of an undamaged stream, in order; asserts the layout and both CRCs. `cut_tail`:
    the stream may end within a frame (a recording killed while writing it), which is left out."""
    frames, at = [], 0
    while at < len(stream):
        if cut_tail and (len(stream) - at < 24 or len(stream) - at < 28 + struct.unpack_from("<H", stream, at + 16)[0]):
            break
        magic, version, kind, sequence, device_us, length, reserved, header_crc = struct.unpack_from("<2sBBIQHHI", stream, at)
        assert magic == b"GP" and version == 1 and reserved == 0, f"frame at byte {at}: magic {magic!r}, version {version}"
        assert header_crc == zlib.crc32(stream[at:at + 20]), f"frame at byte {at}: header CRC"
        payload = stream[at + 24:at + 24 + length]
        (payload_crc,) = struct.unpack_from("<I", stream, at + 24 + length)
        assert payload_crc == zlib.crc32(payload), f"frame at byte {at}: payload CRC"
        frames.append(Frame(kind, sequence, device_us, payload, at, at + 28 + length))
        at += 28 + length
    return frames


def encode(kind: int, sequence: int, device_us: int, payload: bytes) -> bytes:
    """A frame as docs/wire_protocol.md lays it out."""
    header = struct.pack("<2sBBIQHH", b"GP", 1, kind, sequence, device_us, len(payload), 0)
    return header + struct.pack("<I", zlib.crc32(header)) + payload + struct.pack("<I", zlib.crc32(payload))
