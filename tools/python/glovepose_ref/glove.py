"""The glove tables of the C++ side (grid/grid_map.hpp, grid/glove_description.hpp), for the U-Net's
input and output maps: which stretch-map slot each cell fills and which pose-map slot each DoF
reads, for the built-in 44-cell glove or a glove description."""
from __future__ import annotations

import json
import math
from typing import List, Optional, Tuple

#: hand::kDofs names, in DoF order (theta 9..33).
DOF_NAMES: Tuple[str, ...] = tuple(
    [f"{f}_{m}" for f in ("thumb", "index", "middle", "ring", "pinky")
     for m in ("base_abduction", "base_flexion", "middle_flexion", "tip_flexion")]
    + [f"{f}_base_twist" for f in ("thumb", "index", "middle", "ring", "pinky")]
)
#: GridMap::paper_pose_slots(): DoF d -> (row = finger, column = motion) of the 5x5 pose map.
BUILTIN_DOF_SLOTS: Tuple[Tuple[int, int], ...] = tuple(
    [(d // 4, d % 4) for d in range(20)] + [(f, 4) for f in range(5)]
)
# GridMap::glauser2019(): rows thumb..pinky; the cell id at each slot, -1 empty.
_ALONG = ((-1, 11, 0, 20, -1), (3, 12, 21, 33, 40), (5, 13, 22, 34, 41), (6, 14, 23, 35, 42), (-1, 15, 24, 36, 32))
_ACROSS = ((16, 2, 1, 28, -1), (25, 4, 29, 37, 43), (26, 7, 30, 38, 17), (27, 19, 31, 39, -1), (18, 10, 8, 9, -1))


def builtin_cell_slots() -> List[Tuple[int, int, int]]:
    """Cell id -> (channel, row, col) in the 2x5x5 stretch maps of the built-in 44-cell glove."""
    slots: List[Optional[Tuple[int, int, int]]] = [None] * 44
    for channel, table in ((0, _ALONG), (1, _ACROSS)):
        for r, row in enumerate(table):
            for c, cell in enumerate(row):
                if cell >= 0:
                    assert slots[cell] is None, f"cell {cell} placed twice"
                    slots[cell] = (channel, r, c)
    assert all(s is not None for s in slots), "a cell of the built-in glove has no slot"
    return [s for s in slots if s is not None]


def glove_tables(glove: str, description: Optional[str]) -> Tuple[List[Optional[Tuple[int, int, int]]], List[Tuple[int, int]]]:
    """(cell slots, DoF slots in hand::kDofs order) of glove `glove`: its description's JSON text,
    or the built-in tables when `description` is None (then `glove` must be 'glauser2019-44'). An
    extra input (`"extra": true`, not on the stretch maps) has the slot None."""
    if description is None:
        if glove != "glauser2019-44":
            raise ValueError(f"glove {glove!r} is not built in, expected its glove description")
        return builtin_cell_slots(), list(BUILTIN_DOF_SLOTS)
    desc = json.loads(description)
    cells = [None if c.get("extra") else (int(c["channel"]), int(c["row"]), int(c["col"])) for c in desc["cells"]]
    by_name = {d["name"]: (int(d["row"]), int(d["col"])) for d in desc["dofs"]}
    return cells, [by_name[n] for n in DOF_NAMES]


def glove_settings(description: Optional[str], joint_limits_min, joint_limits_max) -> dict:
    """The description's settings (grid/glove_description.hpp), defaults where it has none:
    median_seconds, flat_relative_range, rate_hz (None when not given), and the joint limits in
    radians (the description's degrees where a DoF has them, else the given reference limits)."""
    desc = json.loads(description) if description is not None else {}
    calibration = desc.get("calibration", {})
    lo, hi = list(joint_limits_min), list(joint_limits_max)
    for entry in desc.get("dofs", []):
        if "min_degrees" in entry:
            d = DOF_NAMES.index(entry["name"])
            lo[d] = float(entry["min_degrees"]) * (math.pi / 180.0)
            hi[d] = float(entry["max_degrees"]) * (math.pi / 180.0)
    return {"median_seconds": float(calibration.get("median_seconds", 1.0 / 3.0)),
            "flat_relative_range": float(calibration.get("flat_relative_range", 0.01)),
            "rate_hz": desc.get("rate_hz"), "joint_limits_min": lo, "joint_limits_max": hi}


def median_frames(median_seconds: float, frames_per_second: float) -> int:
    """GloveCalibration::median_frames: the window in frames (rounded half away from zero, >= 1)."""
    return max(1, int(math.floor(median_seconds * frames_per_second + 0.5)))
