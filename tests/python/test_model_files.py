#!/usr/bin/env python3
"""Model files of every architecture (unet, fcn, linear) between PyTorch and the C++ tool.

(a) glovepose_ref.export_model -> import_model round trips of UNet, FCN and torch.nn.Linear(inputs,
    25), stored F32, F16 and BF16, and what import/export refuse.
(b) Files written by `glovepose train` (unet:4, fcn:8, linear; F32 and --dtype f16) load with
    import_model. The U-Net's PyTorch forward, with the cells -> stretch-maps scatter, the pose
    map -> DoF order and the de-normalisation redone here, equals `glovepose predict` within 1e-4
    rad. FCN and linear models (which `predict` does not take) are checked for shapes and finite
    outputs, and, like the U-Net, against `glovepose eval --calibration-mode none` (mean and max angle
    error on the corpus's recording frames). The other way round, files of export_model (U-Net
    F16, FCN BF16, linear F32) give the same predictions in the tool as in PyTorch. So does a U-Net
    for a glove with 2 extra inputs (input planes 2 + 2, the extras at inputs 3 and 15), its planes
    built here from the glove description; import refuses an enc1 whose plane count does not fit it.

Run: /usr/bin/python3 tests/python/test_model_files.py    (exit code 0 when every check passes;
the last line reads 'N passed, N failed, N skipped'). The tool is GLOVEPOSE_CLI, by default
build/tools/glovepose of this checkout; when the default is absent, the (b) checks are skipped
(an explicitly set GLOVEPOSE_CLI that does not exist fails). Uses one CPU thread.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "python"))

import torch  # noqa: E402
from torch import nn  # noqa: E402

torch.set_num_threads(1)

from runner import Skip, Suite, expect_error  # noqa: E402
from glovepose_ref import FCN, UNet, export_model, import_model, randomize, randomize_fcn  # noqa: E402
from glovepose_ref import glove, safetensors_io  # noqa: E402
from glovepose_ref.glove import BUILTIN_DOF_SLOTS, DOF_NAMES, builtin_cell_slots  # noqa: E402
from glovepose_ref.export import (  # noqa: E402
    JOINT_LIMITS_MAX,
    JOINT_LIMITS_MIN,
    ModelFileError,
    ModelInfo,
    import_model_with_info,
    model_metadata,
)

SUITE = Suite(prefix="glovepose_model_files_")
TMP = SUITE.tmp
test = SUITE.test
DTYPES = {"F32": torch.float32, "F16": torch.float16, "BF16": torch.bfloat16}
TOLERANCE_RAD = 1e-4

_cli_env = os.environ.get("GLOVEPOSE_CLI")
CLI = Path(_cli_env) if _cli_env else ROOT / "build" / "tools" / "glovepose"
CLI_REQUIRED = bool(_cli_env)


def stored_tensors(model: nn.Module) -> Dict[str, torch.Tensor]:
    return {k: v for k, v in model.state_dict().items() if not k.endswith("num_batches_tracked")}


def random_linear(inputs: int, seed: int) -> nn.Linear:
    g = torch.Generator().manual_seed(seed)
    m = nn.Linear(inputs, 25)
    with torch.no_grad():
        m.weight.copy_(torch.rand(m.weight.shape, generator=g) * 0.4 - 0.2)
        m.bias.copy_(torch.rand(m.bias.shape, generator=g) * 0.2 - 0.1)
    return m


# ---------------------------------------------------------------------------------------------
# (a) Python round trips
# ---------------------------------------------------------------------------------------------


def check_roundtrip(model: nn.Module, x: torch.Tensor, name: str, expect_meta: Dict[str, Optional[str]]) -> None:
    """export in every dtype, import, compare tensors, forward and metadata."""
    model = model.eval()
    for dtype, tdt in DTYPES.items():
        p = TMP / f"{name}_{dtype}.safetensors"
        export_model(model, p, dtype=dtype)
        tensors, meta = safetensors_io.load(p)
        assert all(t.dtype == tdt for t in tensors.values()), (name, dtype)
        assert set(tensors) == set(stored_tensors(model)), (name, sorted(tensors))
        for key, want in expect_meta.items():
            assert meta.get(key) == want, (name, dtype, key, meta.get(key), want)
        r = import_model(p)
        assert type(r) is type(model), (name, type(r))
        assert not r.training
        rs = r.state_dict()
        for k, v in stored_tensors(model).items():
            assert rs[k].dtype == torch.float32, (name, dtype, k, rs[k].dtype)
            assert torch.equal(rs[k], v.to(tdt).float()), (name, dtype, k)
        with torch.no_grad():
            y, yr = model(x), r(x)
        if dtype == "F32":
            assert torch.equal(y, yr), (name, dtype)
        else:
            # Rounded weights: close, not equal (the values are small, the nets tiny).
            assert float((y - yr).abs().max()) < 0.1, (name, dtype, float((y - yr).abs().max()))


@test
def test_roundtrip_unet() -> None:
    x = torch.rand(6, 2, 5, 5, generator=torch.Generator().manual_seed(1)) * 2.4 - 1.2
    check_roundtrip(randomize(UNet(4), 11), x, "unet",
                    {"architecture": "unet", "width": "4", "inputs": None, "bn_eps": "1e-05"})
    # inputs given for a U-Net is written; the module type comes back.
    p = TMP / "unet_inputs.safetensors"
    export_model(randomize(UNet(4), 11), p, inputs=44)
    m, info = import_model_with_info(p)
    assert isinstance(m, UNet) and m.width == 4
    assert info.architecture == "unet" and info.width == 4 and info.inputs == 44
    assert safetensors_io.load(p)[1]["inputs"] == "44"


@test
def test_roundtrip_fcn() -> None:
    x = torch.rand(6, 44, generator=torch.Generator().manual_seed(2)) * 2.4 - 1.2
    check_roundtrip(randomize_fcn(FCN(44, 8), 12), x, "fcn",
                    {"architecture": "fcn", "width": "8", "inputs": "44", "bn_eps": "1e-05"})
    m, info = import_model_with_info(TMP / "fcn_F32.safetensors")
    assert isinstance(m, FCN) and (m.inputs, m.hidden, m.outputs) == (44, 8, 25)
    assert (info.architecture, info.width, info.inputs) == ("fcn", 8, 44)
    # Odd hidden width: fc5 has h // 2 outputs, as on the C++ side.
    check_roundtrip(randomize_fcn(FCN(44, 5), 13), x, "fcn5", {"architecture": "fcn", "width": "5"})


@test
def test_roundtrip_linear() -> None:
    x = torch.rand(6, 44, generator=torch.Generator().manual_seed(3)) * 2.4 - 1.2
    check_roundtrip(random_linear(44, 14), x, "linear",
                    {"architecture": "linear", "width": None, "inputs": "44", "bn_eps": "1e-05"})
    tensors, _ = safetensors_io.load(TMP / "linear_F32.safetensors")
    assert sorted(tensors) == ["bias", "weight"]
    assert list(tensors["weight"].shape) == [25, 44] and list(tensors["bias"].shape) == [25]
    m, info = import_model_with_info(TMP / "linear_F32.safetensors")
    assert isinstance(m, nn.Linear) and (m.in_features, m.out_features) == (44, 25)
    assert (info.architecture, info.width, info.inputs) == ("linear", 0, 44)


@test
def test_metadata_options() -> None:
    # A 3-cell glove described as data, training calibration, provenance.
    dofs = [
        {"name": n, "row": r, "col": c}
        for n, (r, c) in zip(DOF_NAMES, BUILTIN_DOF_SLOTS)
    ]
    desc = {"format": "glovepose-glove", "version": 1, "id": "tiny3",
            "cells": [{"name": f"c{i}", "channel": 0, "row": 0, "col": i} for i in range(3)], "dofs": dofs}
    p = TMP / "fcn_tiny3.safetensors"
    lo = [v - 0.1 for v in JOINT_LIMITS_MIN]
    export_model(randomize_fcn(FCN(3, 4), 1), p, glove="tiny3", joint_limits_min=lo,
                 calibration_min=[0.0, 1.0, 2.0], calibration_max=[1.0, 2.0, 3.5], calibration="training",
                 glove_description=desc, extra_metadata={"training_command": "test", "training_seed": "7"})
    m, info = import_model_with_info(p)
    assert isinstance(m, FCN) and m.inputs == 3
    assert info.glove == "tiny3" and info.inputs == 3 and info.calibration == "training"
    assert json.loads(info.glove_description or "")["id"] == "tiny3"
    assert info.calibration_max == (1.0, 2.0, 3.5)
    assert info.joint_limits_min == tuple(lo) and info.joint_limits_max == tuple(JOINT_LIMITS_MAX)
    assert info.metadata["training_command"] == "test" and info.metadata["training_seed"] == "7"
    # denormalize: -1 -> min, +1 -> max, 0 -> the middle.
    r = info.denormalize(torch.tensor([[-1.0] * 25, [1.0] * 25, [0.0] * 25]))
    assert r.dtype == torch.float64
    assert torch.allclose(r[0], torch.tensor(lo, dtype=torch.float64))
    assert torch.allclose(r[1], torch.tensor(JOINT_LIMITS_MAX, dtype=torch.float64))
    assert torch.allclose(r[2], (r[0] + r[1]) / 2)
    # Files without the newer keys (the first U-Net files) read with the defaults.
    _, info = import_model_with_info(ROOT / "tests" / "fixtures" / "unet_w4.safetensors")
    assert (info.inputs, info.calibration, info.glove_description) == (44, "onthefly", None)


@test
def test_export_rejects() -> None:
    p = TMP / "never.safetensors"
    expect_error(lambda: export_model(nn.Linear(44, 24), p), ValueError, "25")
    expect_error(lambda: export_model(nn.Linear(44, 25, bias=False), p), ValueError, "bias")
    expect_error(lambda: export_model(FCN(44, 8, outputs=26), p), ValueError, "26 outputs")
    expect_error(lambda: export_model(nn.Conv2d(2, 1, 3), p), TypeError, "Conv2d")
    expect_error(lambda: export_model(FCN(44, 8), p, inputs=43), ValueError, "takes 44 inputs")
    expect_error(lambda: export_model(nn.Linear(14, 25), p), ValueError, "built-in glove")
    expect_error(lambda: export_model(FCN(44, 8), p, extra_metadata={"width": "9"}), ValueError, "width")
    expect_error(lambda: export_model(FCN(44, 8), p, calibration="training"), ValueError, "calibration_min")
    expect_error(lambda: export_model(FCN(44, 8), p, calibration="sometimes"), ValueError, "calibration")
    expect_error(lambda: export_model(FCN(44, 8), p, calibration_min=[0.0] * 43, calibration_max=[1.0] * 43),
                 ValueError, "expected 44")
    expect_error(lambda: model_metadata(4, architecture="linear"), ValueError, "linear")
    expect_error(lambda: model_metadata(None, architecture="fcn"), ValueError, "width")
    bad = random_linear(44, 1)
    with torch.no_grad():
        bad.weight[3, 4] = 1e6  # overflows F16
    expect_error(lambda: export_model(bad, p, dtype="F16"), ValueError, "non-finite")
    assert not p.exists()


@test
def test_import_rejects() -> None:
    p = TMP / "bad.safetensors"
    fcn = stored_tensors(randomize_fcn(FCN(44, 8), 1))
    lin = stored_tensors(random_linear(44, 1))
    fcn_meta = model_metadata(8, architecture="fcn", inputs=44)
    lin_meta = model_metadata(None, architecture="linear", inputs=44)

    def write(tensors: Dict[str, torch.Tensor], meta: Dict[str, str]) -> None:
        safetensors_io.save(p, tensors, meta)

    def rejects(fragment: str) -> None:
        expect_error(lambda: import_model(p), ModelFileError, fragment)

    write({k: v for k, v in fcn.items() if k != "fc3.bias"}, fcn_meta)
    rejects("fc3.bias")
    write(dict(fcn, extra=torch.zeros(1)), fcn_meta)
    rejects("extra")
    write(fcn, dict(fcn_meta, width="9"))
    rejects("shape")
    write(fcn, dict(fcn_meta, width="1"))
    rejects("width")
    write(fcn, dict(fcn_meta, inputs="43", glove="other"))
    rejects("fc1.weight")
    write(dict(fcn, **{"fc6.bias": fcn["fc6.bias"].double()}), fcn_meta)
    rejects("F64")
    write(dict(fcn, **{"fc2.weight": fcn["fc2.weight"].clone().fill_(float("inf"))}), fcn_meta)
    rejects("non-finite")
    write(lin, dict(lin_meta, architecture="resnet"))
    rejects("architecture")
    write({"weight": lin["weight"]}, lin_meta)
    rejects("bias")
    write(dict(lin, **{"fc1.weight": lin["weight"]}), lin_meta)
    rejects("fc1.weight")
    write({"weight": lin["weight"][:, :40].contiguous(), "bias": lin["bias"]}, dict(lin_meta, inputs="40", glove="g40"))
    assert isinstance(import_model(p), nn.Linear) and import_model(p).in_features == 40
    write({"weight": lin["weight"][:, :40].contiguous(), "bias": lin["bias"]}, lin_meta)
    rejects("weight")
    write(lin, dict(lin_meta, inputs="40"))
    rejects("built-in glove")
    write(lin, dict(lin_meta, calibration="training"))
    rejects("calibration")
    write(lin, dict(lin_meta, calibration_min=json.dumps([0.0] * 44)))
    rejects("calibration_max")
    write(lin, dict(lin_meta, joint_limits_max=json.dumps(list(JOINT_LIMITS_MIN))))
    rejects("not below max")
    write(lin, dict(lin_meta, bn_eps="0"))
    rejects("bn_eps")
    # width is ignored for linear models, as by the C++ reader.
    write(lin, dict(lin_meta, width="3"))
    assert isinstance(import_model(p), nn.Linear)


# ---------------------------------------------------------------------------------------------
# The glove tables of the C++ side, for the U-Net's input and output maps
# ---------------------------------------------------------------------------------------------

def glove_tables(info: ModelInfo) -> Tuple[List[Tuple[int, int, int]], List[Tuple[int, int]]]:
    """(cell slots, DoF slots in hand::kDofs order) of the glove a model was trained for."""
    return glove.glove_tables(info.glove, info.glove_description)


def unet_predict_radians(model: UNet, info: ModelInfo, cells: torch.Tensor) -> torch.Tensor:
    """What `glovepose predict` computes, in PyTorch: [N, cells] calibrated values -> [N, 25] radians.

    GridMap::to_stretch_maps (empty slots 0, float32), the U-Net, GridMap::from_pose_map, held
    within the joint limits ([-1, 1]) and JointLimits::denormalize (float64).
    """
    cell_slots, dof_slots = glove_tables(info)
    assert cells.shape[1] == len(cell_slots) == info.inputs
    maps = torch.zeros(cells.shape[0], 2, 5, 5, dtype=torch.float32)
    for i, (ch, r, c) in enumerate(cell_slots):
        maps[:, ch, r, c] = cells[:, i].to(torch.float32)
    with torch.no_grad():
        pose = model(maps)[:, 0]
    normalized = torch.stack([pose[:, r, c] for r, c in dof_slots], dim=1)
    return info.denormalize(normalized.clamp(-1.0, 1.0))


@test
def test_builtin_tables() -> None:
    slots = builtin_cell_slots()
    assert len(set(slots)) == 44
    assert slots[0] == (0, 0, 2) and slots[17] == (1, 2, 4) and slots[32] == (0, 4, 4) and slots[43] == (1, 1, 4)
    assert len(set(BUILTIN_DOF_SLOTS)) == 25 and len(DOF_NAMES) == 25
    assert DOF_NAMES[0] == "thumb_base_abduction" and DOF_NAMES[20] == "thumb_base_twist"
    assert BUILTIN_DOF_SLOTS[20] == (0, 4) and BUILTIN_DOF_SLOTS[24] == (4, 4) and BUILTIN_DOF_SLOTS[13] == (3, 1)


# ---------------------------------------------------------------------------------------------
# (b) Files of the C++ tool
# ---------------------------------------------------------------------------------------------

_cli_dir: Optional[Path] = None


def run_cli(args: Sequence[str], cwd: Path) -> str:
    proc = subprocess.run([str(CLI), *args], cwd=cwd, capture_output=True, text=True, timeout=300)
    if proc.returncode != 0:
        raise AssertionError(f"glovepose {' '.join(args)} exited with {proc.returncode}:\n{proc.stdout}\n{proc.stderr}")
    return proc.stdout


MODELS = {  # file stem -> train arguments
    "unet": ["--architecture", "unet:4"],
    "unet_f16": ["--architecture", "unet:4", "--weights", "f16"],
    "fcn": ["--architecture", "fcn:8"],
    "fcn_f16": ["--architecture", "fcn:8", "--weights", "f16"],
    "linear": ["--architecture", "linear"],
    "linear_f16": ["--architecture", "linear", "--weights", "f16"],
}
#: Models written by export_model for the C++ tool to read: file stem -> (module, dtype).
PY_MODELS = {
    "py_unet": (lambda: randomize(UNet(4), 21), "F16"),
    "py_fcn": (lambda: randomize_fcn(FCN(44, 8), 22), "BF16"),
    "py_linear": (lambda: random_linear(44, 23), "F32"),
}


def cli_dir() -> Path:
    """A temporary directory with a tiny simulated corpus c.safetensors, the models of MODELS
    (trained by the tool) and of PY_MODELS (written by export_model)."""
    global _cli_dir
    if _cli_dir is not None:
        return _cli_dir
    if not CLI.is_file():
        if CLI_REQUIRED:
            raise AssertionError(f"GLOVEPOSE_CLI={CLI} does not exist")
        raise Skip(f"no glovepose binary at {CLI} (build it, or set GLOVEPOSE_CLI)")
    d = TMP / "cli"
    d.mkdir(exist_ok=True)
    run_cli(["simulate", "--world", "clean", "--seed", "3", "--subjects", "2", "--sessions", "2", "--minutes", "0.2", "--gloves", "1",
             "--calibration-seconds", "5", "--threads", "1", "--out", "c.safetensors"], d)
    for stem, model_args in MODELS.items():
        run_cli(["train", "--data", "c.safetensors", *model_args, "--epochs", "1", "--threads", "1", "--batch", "64",
                 "--quiet", "--out", f"{stem}.safetensors"], d)
    for stem, (make, dtype) in PY_MODELS.items():
        export_model(make().eval(), d / f"{stem}.safetensors", dtype=dtype)
    _cli_dir = d
    return d


@test
def test_cli_files_load() -> None:
    d = cli_dir()
    want = {"unet": UNet, "fcn": FCN, "linear": nn.Linear}
    for stem in MODELS:
        arch = stem.split("_")[0]
        tensors, _ = safetensors_io.load(d / f"{stem}.safetensors")
        stored = {t.dtype for t in tensors.values()}
        assert stored == {torch.float16 if stem.endswith("_f16") else torch.float32}, (stem, stored)
        m, info = import_model_with_info(d / f"{stem}.safetensors")
        assert type(m) is want[arch], (stem, type(m))
        assert info.architecture == arch and info.inputs == 44 and info.glove == "glauser2019-44", (stem, info)
        assert info.width == {"unet": 4, "fcn": 8, "linear": 0}[arch], (stem, info.width)
        assert "training_command" in info.metadata, stem
        assert all(v.dtype == torch.float32 for v in m.state_dict().values() if v.is_floating_point()), stem
        # 16-bit files: the float32 weights are the stored values widened.
        for k, t in tensors.items():
            assert torch.equal(m.state_dict()[k], t.float()), (stem, k)
        if arch == "fcn":
            assert (m.inputs, m.hidden, m.outputs) == (44, 8, 25)
            assert list(m.fc1.weight.shape) == [8, 44] and list(m.fc5.weight.shape) == [4, 8]
            assert list(m.fc6.weight.shape) == [25, 4]
        if arch == "linear":
            assert (m.in_features, m.out_features) == (44, 25) and sorted(tensors) == ["bias", "weight"]
        if arch in ("fcn", "linear"):
            x = torch.rand(16, 44, generator=torch.Generator().manual_seed(5)) * 2 - 1
            with torch.no_grad():
                y0, y = m(torch.zeros(1, 44)), m(x)
            assert list(y0.shape) == [1, 25] and list(y.shape) == [16, 25], stem
            assert bool(torch.isfinite(y0).all()) and bool(torch.isfinite(y).all()), stem
            assert bool(torch.isfinite(info.denormalize(y)).all()), stem


@test
def test_cli_unet_matches_predict() -> None:
    d = cli_dir()
    g = torch.Generator().manual_seed(7)
    cells = torch.rand(40, 44, generator=g, dtype=torch.float32) * 2.4 - 1.2
    cells[0] = 0.0
    cells[1] = 1.0
    cells[2] = -1.0
    # Each value as the shortest decimal that reads back as the same float32 (via float64, as the tool
    # parses doubles and casts to float).
    csv = d / "cells.csv"
    csv.write_text("".join(",".join(repr(float(v)) for v in row.tolist()) + "\n" for row in cells))
    for stem in ("unet", "unet_f16", "py_unet"):
        out = run_cli(["predict", "--model", f"{stem}.safetensors", "--in", str(csv), "--no-header"], d)
        rows = [[float(v) for v in line.split(",")] for line in out.strip().splitlines()]
        cpp = torch.tensor(rows, dtype=torch.float64)
        assert list(cpp.shape) == [40, 25], (stem, list(cpp.shape))
        m, info = import_model_with_info(d / f"{stem}.safetensors")
        ours = unet_predict_radians(m, info, cells)
        diff = float((ours - cpp).abs().max())
        assert diff <= TOLERANCE_RAD, f"{stem}: PyTorch vs glovepose predict differ by {diff} rad, expected <= {TOLERANCE_RAD}"
        # A check that checks something: the outputs vary with the input.
        assert float(cpp.std(dim=0).max()) > 1e-3, f"{stem}: predictions hardly depend on the input"
        print(f"     {stem}: max |PyTorch - glovepose predict| = {diff:.2e} rad over {cpp.numel()} angles")


#: Input positions of the extra inputs of the glove of extra_inputs_description(): between the
#: stretch cells and after them, so that they are not simply the last inputs.
EXTRA_POSITIONS = (3, 15)


def extra_inputs_description() -> Dict[str, object]:
    """A 16-input glove: 14 stretch cells on the built-in glove's slots of cells 0..13, and the extra
    inputs (not on the stretch maps) 'imu_roll' at input 3 and 'wrist_bend' at input 15."""
    stretch = iter(builtin_cell_slots()[:14])
    cells: List[Dict[str, object]] = []
    for i in range(14 + len(EXTRA_POSITIONS)):
        if i in EXTRA_POSITIONS:
            cells.append({"name": "imu_roll" if i == EXTRA_POSITIONS[0] else "wrist_bend", "extra": True})
        else:
            ch, r, c = next(stretch)
            cells.append({"name": f"s{i}", "channel": ch, "row": r, "col": c})
    dofs = [{"name": n, "row": r, "col": c} for n, (r, c) in zip(DOF_NAMES, BUILTIN_DOF_SLOTS)]
    return {"format": "glovepose-glove", "version": 1, "id": "extra16", "cells": cells, "dofs": dofs}


def unet_extra_predict_radians(model: UNet, desc: Dict[str, object], cells: torch.Tensor) -> torch.Tensor:
    """`glovepose predict` for a glove with extra inputs, written out here from the description alone:
    [N, 16] calibrated values -> the [N, 2 + E, 5, 5] planes (stretch cells at their slots, 0
    elsewhere; then one constant plane per extra input, in input order) -> U-Net -> DoFs read at the
    description's pose-map slots -> held within the joint limits -> the reference joint limits (float64)."""
    cell_list = desc["cells"]
    extra_count = sum(1 for c in cell_list if c.get("extra"))
    n = cells.shape[0]
    planes = torch.zeros(n, 2 + extra_count, 5, 5, dtype=torch.float32)
    plane = 2
    for i, cell in enumerate(cell_list):
        value = cells[:, i].to(torch.float32)
        if cell.get("extra"):
            planes[:, plane] = value.view(n, 1, 1)
            plane += 1
        else:
            planes[:, cell["channel"], cell["row"], cell["col"]] = value
    assert plane == 2 + extra_count
    slot = {d["name"]: (d["row"], d["col"]) for d in desc["dofs"]}
    with torch.no_grad():
        pose = model(planes)[:, 0]
    normalized = torch.stack([pose[:, slot[name][0], slot[name][1]] for name in DOF_NAMES], dim=1).to(torch.float64).clamp(-1.0, 1.0)
    lo = torch.tensor(JOINT_LIMITS_MIN, dtype=torch.float64)
    hi = torch.tensor(JOINT_LIMITS_MAX, dtype=torch.float64)
    return lo + 0.5 * (normalized + 1.0) * (hi - lo)


@test
def test_unet_extra_inputs_file() -> None:
    """A U-Net for a glove with 2 extra inputs: export -> import keeps E = 2 (enc1.weight [w, 4, 5, 5]);
    an enc1 reading 2 + 1 planes under a description with 2 extra inputs is refused both ways."""
    desc = extra_inputs_description()
    p = TMP / "unet_extra.safetensors"
    model = randomize(UNet(4, extra_inputs=2), 31).eval()
    export_model(model, p, glove="extra16", glove_description=desc)
    tensors, meta = safetensors_io.load(p)
    assert list(tensors["enc1.weight"].shape) == [4, 4, 5, 5], list(tensors["enc1.weight"].shape)
    assert meta["inputs"] == "16"
    m, info = import_model_with_info(p)
    assert isinstance(m, UNet) and m.extra_inputs == 2 and info.extra_inputs == 2 and info.inputs == 16
    for k, v in stored_tensors(model).items():
        assert torch.equal(m.state_dict()[k], v), k
    # The extra planes matter: other extra values, other outputs (a forward that ignored them would pass).
    cells = torch.rand(4, 16, generator=torch.Generator().manual_seed(8)) * 2 - 1
    shifted = cells.clone()
    shifted[:, list(EXTRA_POSITIONS)] += 0.5
    d = (unet_extra_predict_radians(m, desc, cells) - unet_extra_predict_radians(m, desc, shifted)).abs().max()
    assert float(d) > 1e-3, float(d)
    # enc1 reading 2 + 1 planes, description with 2 extra inputs.
    one = stored_tensors(randomize(UNet(4, extra_inputs=1), 32))
    bad = TMP / "unet_extra_mismatch.safetensors"
    safetensors_io.save(bad, one, model_metadata(4, glove="extra16", glove_description=desc))
    expect_error(lambda: import_model(bad), ModelFileError, "extra")
    expect_error(lambda: import_model(bad), ModelFileError, "enc1.weight [w, 3, 5, 5]")
    expect_error(lambda: export_model(randomize(UNet(4, extra_inputs=1), 32), TMP / "never_extra.safetensors",
                                      glove="extra16", glove_description=desc), ValueError, "extra")
    assert not (TMP / "never_extra.safetensors").exists()


@test
def test_cli_unet_extra_inputs_matches_predict() -> None:
    """export_model's U-Net (width 4, 2 extra inputs at input positions 3 and 15) in `glovepose
    predict` equals the forward written out in unet_extra_predict_radians within TOLERANCE_RAD."""
    d = cli_dir()
    desc = extra_inputs_description()
    model = randomize(UNet(4, extra_inputs=2), 33).eval()
    export_model(model, d / "py_unet_extra.safetensors", glove="extra16", glove_description=desc)
    g = torch.Generator().manual_seed(9)
    cells = torch.rand(24, 16, generator=g, dtype=torch.float32) * 2.4 - 1.2
    cells[0] = 0.0
    cells[1] = 1.0
    cells[2] = -1.0
    # Rows 4 and 5: row 3 with only the extra inputs changed; rows 6 and 7: row 3 with only the stretch cells changed.
    cells[4] = cells[3]
    cells[4, EXTRA_POSITIONS[0]] = -cells[3, EXTRA_POSITIONS[0]]
    cells[5] = cells[3]
    cells[5, EXTRA_POSITIONS[1]] = -cells[3, EXTRA_POSITIONS[1]]
    stretch = [i for i in range(16) if i not in EXTRA_POSITIONS]
    cells[6] = cells[3]
    cells[6, stretch] = -cells[3, stretch]
    cells[7] = cells[6]
    csv = d / "cells_extra.csv"
    csv.write_text("".join(",".join(repr(float(v)) for v in row.tolist()) + "\n" for row in cells))
    out = run_cli(["predict", "--model", "py_unet_extra.safetensors", "--in", str(csv), "--no-header"], d)
    cpp = torch.tensor([[float(v) for v in line.split(",")] for line in out.strip().splitlines()], dtype=torch.float64)
    assert list(cpp.shape) == [24, 25], list(cpp.shape)
    ours = unet_extra_predict_radians(model, desc, cells)
    diff = float((ours - cpp).abs().max())
    assert diff <= TOLERANCE_RAD, f"PyTorch vs glovepose predict differ by {diff} rad, expected <= {TOLERANCE_RAD}"
    assert float(cpp.std(dim=0).max()) > 1e-3, "predictions hardly depend on the input"
    # Each extra input, alone, moves the tool's prediction; identical rows give identical predictions.
    for row in (4, 5, 6):
        assert float((cpp[row] - cpp[3]).abs().max()) > 1e-4, (row, float((cpp[row] - cpp[3]).abs().max()))
    assert torch.equal(cpp[6], cpp[7])
    # Extras in the wrong planes (swapped) or appended last would not match: the check tells them apart.
    swapped = desc["cells"][:]
    swapped[EXTRA_POSITIONS[0]], swapped[EXTRA_POSITIONS[1]] = swapped[EXTRA_POSITIONS[1]], swapped[EXTRA_POSITIONS[0]]
    perm = list(range(16))
    perm[EXTRA_POSITIONS[0]], perm[EXTRA_POSITIONS[1]] = perm[EXTRA_POSITIONS[1]], perm[EXTRA_POSITIONS[0]]
    wrong = float((unet_extra_predict_radians(model, dict(desc, cells=swapped), cells[:, perm]) - cpp).abs().max())
    assert wrong > 100 * TOLERANCE_RAD, f"swapping the extra planes changes the prediction by only {wrong} rad"
    print(f"     py_unet_extra: max |PyTorch - glovepose predict| = {diff:.2e} rad over {cpp.numel()} angles "
          f"(extra planes swapped: {wrong:.2e} rad)")


@test
def test_cli_eval_matches() -> None:
    """`glovepose eval --calibration-mode none` vs PyTorch on the corpus's recording frames (kind 0, not
    outliers): the raw cell capacitances go into each model as they are, so no calibration is redone;
    every model's outputs held within [-1, 1] (the joint limits), as glovepose holds them.
    Covers the tool's files and export_model's (the tool reads FCN and linear files only this way)."""
    d = cli_dir()
    data, _ = safetensors_io.load(d / "c.safetensors")
    keep = (data["kind"] == 0) & (data["outlier"] == 0)
    cells, truth = data["cells"][keep], data["angles"][keep].double()
    for stem in [*MODELS, *PY_MODELS]:
        report = json.loads(run_cli(["eval", "--model", f"{stem}.safetensors", "--data", "c.safetensors",
                                     "--calibration-mode", "none", "--json", "--threads", "1"], d))
        m, info = import_model_with_info(d / f"{stem}.safetensors")
        if isinstance(m, UNet):
            radians = unet_predict_radians(m, info, cells)
        else:
            with torch.no_grad():
                radians = info.denormalize(m(cells).clamp(-1.0, 1.0))  # glovepose holds every model's angles within the joint limits
        err = (radians - truth).abs() * (180.0 / torch.pi)
        assert report["frames"] == cells.shape[0], (stem, report["frames"], cells.shape[0])
        mean, top = float(err.mean()), float(err.max())
        assert abs(mean - report["mean_deg"]) <= 1e-5 * max(1.0, report["mean_deg"]), (stem, mean, report["mean_deg"])
        assert abs(top - report["max_deg"]) <= 1e-3, (stem, top, report["max_deg"])
        print(f"     {stem}: mean error {mean:.6f} deg (glovepose eval {report['mean_deg']:.6f}), {report['frames']} frames")


if __name__ == "__main__":
    sys.exit(SUITE.run())
