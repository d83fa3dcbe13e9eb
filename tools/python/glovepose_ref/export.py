"""Writing and reading glovepose model files (weights_format.md, "Metadata of a model file").

`export_model` stores a UNet's state_dict (without the `num_batches_tracked` training counters) and
the metadata; `import_model` rebuilds the UNet, loading strictly, and checks the metadata.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Dict, Optional, Sequence, Union

import torch

from . import safetensors_io
from .model import UNet

PathLike = Union[str, Path]

FORMAT = "glovepose-model"
FORMAT_VERSION = "1"
ARCHITECTURE = "unet"
DEFAULT_GLOVE = "glauser2019-44"

# The reference hand model's limits of theta[9..33], radians, in theta order (the order of
# glovepose::kDofs). Source: shared/reference/hand_model.md, table "The 34 parameters, their order
# and limits", rows 9..33 (Tkach et al. 2017, honline tracker ModelSemantics.cpp).
JOINT_LIMITS_MIN: tuple = (
    -0.1, -0.5, -0.9, -1.4,     # 9-12  thumb: base abduction, base flexion, middle, tip flexion
    -0.30, -1.3, -0.1, -0.1,    # 13-16 index
    -0.30, -1.3, -0.1, -0.1,    # 17-20 middle
    -0.10, -1.3, -0.1, -0.1,    # 21-24 ring
    -0.20, -1.3, -0.1, -0.1,    # 25-28 pinky
    -0.40, -0.45, -0.15, -0.10, -0.10,  # 29-33 base twist: thumb, index, middle, ring, pinky
)
JOINT_LIMITS_MAX: tuple = (
    1.0, 1.0, 0.9, 0.7,         # 9-12  thumb
    0.35, 1.6, 2.0, 2.0,        # 13-16 index
    0.40, 1.6, 2.0, 2.0,        # 17-20 middle
    0.30, 1.6, 2.0, 2.0,        # 21-24 ring
    0.65, 1.6, 2.0, 2.0,        # 25-28 pinky
    0.40, 0.05, 0.05, 0.05, 0.05,  # 29-33 base twist
)
DOF_COUNT = 25

_SAVE_DTYPES = {"F32": torch.float32, "F16": torch.float16, "BF16": torch.bfloat16}


class ModelFileError(ValueError):
    """A model file whose metadata or tensors do not match what glovepose expects."""


def _float_array(values: Sequence[float], what: str, length: Optional[int] = None) -> str:
    """A JSON array of finite floats with repr precision (json.dumps uses float.__repr__)."""
    vals = [float(v) for v in values]
    if length is not None and len(vals) != length:
        raise ValueError(f"{what}: {len(vals)} values, expected {length}")
    for i, v in enumerate(vals):
        if not math.isfinite(v):
            raise ValueError(f"{what}[{i}] = {v}, expected a finite number")
    return json.dumps(vals)


def model_tensors(model: UNet) -> Dict[str, torch.Tensor]:
    """The tensors a model file stores: the state_dict without `num_batches_tracked`."""
    return {k: v.detach().clone() for k, v in model.state_dict().items() if not k.endswith("num_batches_tracked")}


def model_metadata(
    width: int,
    glove: str = DEFAULT_GLOVE,
    joint_limits_min: Optional[Sequence[float]] = None,
    joint_limits_max: Optional[Sequence[float]] = None,
    calibration_min: Optional[Sequence[float]] = None,
    calibration_max: Optional[Sequence[float]] = None,
) -> Dict[str, str]:
    """The metadata dict of a model file; joint limits default to the reference hand model's."""
    lo = JOINT_LIMITS_MIN if joint_limits_min is None else joint_limits_min
    hi = JOINT_LIMITS_MAX if joint_limits_max is None else joint_limits_max
    lo_s = _float_array(lo, "joint_limits_min", DOF_COUNT)
    hi_s = _float_array(hi, "joint_limits_max", DOF_COUNT)
    for i, (a, b) in enumerate(zip(lo, hi)):
        if not a < b:
            raise ValueError(f"joint limits of DoF {i} (theta {9 + i}): min {a} is not below max {b}")
    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "architecture": ARCHITECTURE,
        "width": str(int(width)),
        "glove": glove,
        "bn_eps": "1e-05",
        "joint_limits_min": lo_s,
        "joint_limits_max": hi_s,
    }
    if (calibration_min is None) != (calibration_max is None):
        raise ValueError("calibration_min and calibration_max must be given together")
    if calibration_min is not None and calibration_max is not None:
        cmin = _float_array(calibration_min, "calibration_min")
        cmax = _float_array(calibration_max, "calibration_max", len(calibration_min))
        meta["calibration_min"] = cmin
        meta["calibration_max"] = cmax
    return meta


def export_model(
    model: UNet,
    path: PathLike,
    glove: str = DEFAULT_GLOVE,
    joint_limits_min: Optional[Sequence[float]] = None,
    joint_limits_max: Optional[Sequence[float]] = None,
    calibration_min: Optional[Sequence[float]] = None,
    calibration_max: Optional[Sequence[float]] = None,
    dtype: str = "F32",
) -> None:
    """Writes `model` to `path` as a glovepose model file.

    dtype: 'F32' (default; models are trained in F32), 'F16' or 'BF16' (values rounded on write).
    Raises ValueError for non-finite weights or bad metadata.
    """
    if dtype not in _SAVE_DTYPES:
        raise ValueError(f"dtype {dtype!r}, expected one of {sorted(_SAVE_DTYPES)}")
    for m in model.modules():
        if isinstance(m, torch.nn.BatchNorm2d) and m.eps != 1e-5:
            raise ValueError(f"BatchNorm eps {m.eps}, the format fixes bn_eps = 1e-05")
    tensors = {k: v.to(_SAVE_DTYPES[dtype]) for k, v in model_tensors(model).items()}
    for k, v in tensors.items():
        if not torch.isfinite(v).all():
            raise ValueError(f"tensor '{k}' has non-finite values (after conversion to {dtype})")
    meta = model_metadata(model.width, glove, joint_limits_min, joint_limits_max, calibration_min, calibration_max)
    safetensors_io.save(path, tensors, meta)


def check_metadata(meta: Dict[str, str], source: str = "<model>") -> int:
    """Validates a model file's metadata; returns the width."""
    def need(key: str) -> str:
        if key not in meta:
            raise ModelFileError(f"{source}: metadata key '{key}' is missing")
        return meta[key]

    for key, want in (("format", FORMAT), ("format_version", FORMAT_VERSION), ("architecture", ARCHITECTURE)):
        if need(key) != want:
            raise ModelFileError(f"{source}: metadata {key} = {meta[key]!r}, expected {want!r}")
    try:
        width = int(need("width"))
    except ValueError:
        raise ModelFileError(f"{source}: metadata width = {meta['width']!r}, expected an integer")
    if width < 1:
        raise ModelFileError(f"{source}: metadata width = {width}, expected >= 1")
    if float(need("bn_eps")) != 1e-5:
        raise ModelFileError(f"{source}: metadata bn_eps = {meta['bn_eps']!r}, expected '1e-05'")
    need("glove")
    for key in ("joint_limits_min", "joint_limits_max"):
        vals = json.loads(need(key))
        if not isinstance(vals, list) or len(vals) != DOF_COUNT or not all(
            isinstance(v, (int, float)) and math.isfinite(v) for v in vals
        ):
            raise ModelFileError(f"{source}: metadata {key} is not an array of {DOF_COUNT} finite numbers")
    return width


def import_model(path: PathLike) -> UNet:
    """Loads a model file into a UNet in eval mode (strict: no tensor missing or extra, shapes equal).

    16-bit tensors are widened to float32. Raises ModelFileError on bad metadata, names, shapes or
    non-finite values.
    """
    tensors, meta = safetensors_io.load(path)
    width = check_metadata(meta, str(path))
    model = UNet(width)
    expected = model_tensors(model)
    missing = sorted(set(expected) - set(tensors))
    extra = sorted(set(tensors) - set(expected))
    if missing or extra:
        raise ModelFileError(f"{path}: tensors missing {missing}, unexpected {extra}")
    sd = {}
    for k, ref in expected.items():
        t = tensors[k]
        if tuple(t.shape) != tuple(ref.shape):
            raise ModelFileError(f"{path}: tensor '{k}' has shape {list(t.shape)}, expected {list(ref.shape)}")
        if not t.is_floating_point():
            raise ModelFileError(f"{path}: tensor '{k}' has dtype {t.dtype}, expected F32, F16 or BF16")
        t = t.to(torch.float32)
        if not torch.isfinite(t).all():
            raise ModelFileError(f"{path}: tensor '{k}' has non-finite values")
        sd[k] = t
    for k, v in model.state_dict().items():
        if k.endswith("num_batches_tracked"):
            sd[k] = torch.zeros_like(v)
    model.load_state_dict(sd, strict=True)
    model.eval()
    return model
