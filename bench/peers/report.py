#!/usr/bin/env python3
"""Combines the three peer timings into a markdown table (used by bench/peers/run.sh).

Usage: /usr/bin/python3 bench/peers/report.py --width 64 --glovepose GB.json --ort ORT.json --torch TORCH.json

GB.json is Google Benchmark output of build/bench/glovepose_bench run with
--benchmark_repetitions=N --benchmark_report_aggregates_only=true --benchmark_format=json; the
`median` aggregate's real_time of BM_UNetForward{F32|Fixed16|F16|BF16}/<width>/<batch>[/real_time][/threads:N]
(F32 exact; Fixed16 and F16, the two 16-bit storages within 0.1 degree, one of which is the real-time
path, BM_UNetForward, on a given instruction set; BF16) is taken as the time of one
forward of the whole batch (per thread-iteration
with threads:N, i.e. batch / real_time is the N threads' throughput). ORT.json and TORCH.json come from
ort_bench.js and torch_bench.py. Every ratio is (engine's time per frame) / (glovepose F32 time per
frame at the same batch and thread count): above 1 means glovepose is faster.

Also importable: parse_gbench(path_or_dict) -> {run_name: median seconds per iteration}.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path
from typing import Dict, List, Optional, Tuple, Union

_UNIT = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def parse_gbench(src: Union[str, Path, dict], aggregate: str = "median") -> Dict[str, float]:
    """{run_name: real_time in seconds} of each benchmark's `aggregate` row (time_unit honoured)."""
    data = src if isinstance(src, dict) else json.loads(Path(src).read_text())
    out: Dict[str, float] = {}
    for b in data.get("benchmarks", []):
        if b.get("run_type") != "aggregate" or b.get("aggregate_name") != aggregate:
            continue
        if b.get("aggregate_unit", "time") != "time":
            continue
        unit = b.get("time_unit", "ns")
        if unit not in _UNIT:
            raise ValueError(f"{b['name']}: unknown time_unit {unit!r}")
        out[b.get("run_name") or b["name"].rsplit("_", 1)[0]] = float(b["real_time"]) * _UNIT[unit]
    return out


_UNET = re.compile(r"^BM_UNetForward(?P<prec>F32|Fixed16|F16|BF16)/(?P<width>\d+)/(?P<batch>\d+)(?P<rest>(/[^/]+)*)$")
_ENGINE = {"F32": "glovepose F32", "Fixed16": "glovepose Fixed16 weights", "F16": "glovepose F16 weights",
           "BF16": "glovepose BF16 weights"}


def unet_cases(gb: Dict[str, float], width: int) -> List[Tuple[str, int, int, float]]:
    """(precision 'F32'|'Fixed16'|'F16'|'BF16', batch, threads, seconds per run) of the BM_UNetForward cases of `width`.

    Accepts Google Benchmark suffixes such as /real_time and /threads:N. With threads:N, Google
    Benchmark's real_time is wall time / total iterations over all threads, so batch / real_time is
    the throughput of the N threads together (items_per_second).
    """
    out = []
    for name, sec in gb.items():
        m = _UNET.match(name)
        if not m or int(m["width"]) != width:
            continue
        t = re.search(r"/threads:(\d+)", m["rest"] or "")
        out.append((m["prec"], int(m["batch"]), int(t[1]) if t else 1, sec))
    return sorted(out, key=lambda c: (c[1], c[2], c[0] != "F32"))


def _row(engine: str, batch: int, threads: int, sec_per_run: float, base: Optional[float]) -> Dict:
    us = sec_per_run * 1e6 / batch
    return {"engine": engine, "batch": batch, "threads": threads, "us": us, "fps": batch / sec_per_run,
            "ratio": (us / base) if base else None}


def build_rows(width: int, gb: Dict[str, float], ort: dict, torch: dict) -> List[Dict]:
    """Table rows; each ratio is against glovepose F32 at the same batch and thread count."""
    cases = unet_cases(gb, width)
    base = {(b, th): sec * 1e6 / b for prec, b, th, sec in cases if prec == "F32"}
    rows: List[Dict] = []
    batches = sorted({c[1] for c in cases} | {r["batch"] for r in ort["results"]} | {r["batch"] for r in torch["results"]})
    for b in batches:
        for prec, cb, th, sec in cases:
            if cb == b:
                rows.append(_row(_ENGINE[prec], b, th, sec, base.get((b, th))))
        for r in ort["results"]:
            if r["batch"] == b:
                rows.append(_row(f"ONNX Runtime {ort['version']}", b, r["threads"], r["median_s_per_run"],
                                 base.get((b, r["threads"]))))
        for r in torch["results"]:
            if r["batch"] == b:
                label = "PyTorch eager" if r["variant"] == "eager" else "PyTorch (TorchScript frozen)"
                rows.append(_row(f"{label} {torch['version']}", b, r["threads"], r["median_s_per_run"],
                                 base.get((b, r["threads"]))))
    return rows


def markdown(rows: List[Dict]) -> str:
    lines = ["| engine | batch | threads | median time per frame (us) | frames/s | time / glovepose F32 |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        ratio = "n/a" if r["ratio"] is None else f"{r['ratio']:.2f}"
        lines.append(f"| {r['engine']} | {r['batch']} | {r['threads']} | {r['us']:.1f} | {r['fps']:,.0f} | {ratio} |")
    # The requested ratios, one line per batch (single-threaded engines only).
    summary = ["", "| batch | ORT / glovepose | PyTorch / glovepose | PyTorch frozen / glovepose |",
               "|---:|---:|---:|---:|"]
    for b in sorted({r["batch"] for r in rows}):
        summary.append(f"| {b} | {_ratio(rows, b, 'ONNX Runtime')} | {_ratio(rows, b, 'PyTorch eager')} "
                       f"| {_ratio(rows, b, 'PyTorch (TorchScript frozen)')} |")
    return "\n".join(lines + summary)


def _ratio(rows: List[Dict], batch: int, prefix: str) -> str:
    """The ratio of the single-threaded row of `batch` whose engine starts with `prefix`."""
    for r in rows:
        if r["batch"] == batch and r["threads"] == 1 and r["engine"].startswith(prefix) and r["ratio"] is not None:
            return f"{r['ratio']:.2f}"
    return "n/a"


def main(argv: Optional[List[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--glovepose", type=Path, required=True)
    ap.add_argument("--ort", type=Path, required=True)
    ap.add_argument("--torch", type=Path, required=True)
    args = ap.parse_args(argv)
    gb = parse_gbench(args.glovepose)
    have = {(c[1], c[2]) for c in unet_cases(gb, args.width) if c[0] == "F32"}
    missing = [f"BM_UNetForwardF32/{args.width}/{b}" for b in (1, 1024) if (b, 1) not in have]
    if missing:
        print(f"report: {args.glovepose} has no single-thread median for {', '.join(missing)} "
              f"(found: {sorted(gb) or 'nothing'})", file=sys.stderr)
        return 1
    ort = json.loads(args.ort.read_text())
    torch = json.loads(args.torch.read_text())
    print(markdown(build_rows(args.width, gb, ort, torch)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
