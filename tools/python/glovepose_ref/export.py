"""Writing and reading glovepose model files (weights_format.md, "Metadata of a model file").

Three architectures, as `glovepose train` writes them:

    unet    glovepose_ref.UNet(width, E)           metadata width = w; E (the glove's extra inputs,
                                                   0 for most gloves) only from enc1.weight [w, 2 + E, 5, 5]
    fcn     glovepose_ref.FCN(inputs, h, 25)       metadata width = h, inputs = cells
    linear  torch.nn.Linear(inputs, 25)            tensors `weight` [25, inputs], `bias` [25]; no width

`export_model` stores a module's state_dict (without the `num_batches_tracked` training counters)
and the metadata; `import_model` rebuilds the module strictly (every tensor present, none extra,
shapes equal, F32/F16/BF16 widened to float32, all finite) and checks the metadata. A U-Net's
number of extra inputs E is no metadata key: it is read from enc1.weight's shape, and must equal the
glove description's count of extra inputs when the file carries one (0 for the built-in glove).
`import_model_with_info` also returns the parsed metadata (`ModelInfo`, provenance keys included).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, Mapping, Optional, Sequence, Tuple, Union

import torch
from torch import nn

from . import safetensors_io
from .fcn import FCN
from .model import UNet

PathLike = Union[str, Path]
#: What a model file holds: a UNet, an FCN or a torch.nn.Linear(inputs, 25).
ModelModule = Union[UNet, FCN, nn.Linear]

FORMAT = "glovepose-model"
FORMAT_VERSION = "1"
ARCHITECTURE = "unet"  # the default architecture (and the only one before fcn/linear files existed)
ARCHITECTURES = ("unet", "fcn", "linear")
CALIBRATIONS = ("none", "training", "onthefly")
DEFAULT_GLOVE = "glauser2019-44"
DEFAULT_GLOVE_CELLS = 44  # cells of the built-in glove; also the default of metadata `inputs`

# The reference hand model's limits of theta[9..33], radians, in theta order (the order of
# glovepose::kDofs). Source: the hand model of Tkach et al. 2017, public repository
# anastasia-tkach/honline-cpp-public, tracker/HModel/ModelSemantics.cpp (tests/reference/hmodel_template.hpp).
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


#: Metadata keys export_model sets itself (extra_metadata may not set them).
_FORMAT_KEYS = frozenset({
    "format", "format_version", "architecture", "width", "inputs", "glove", "glove_description", "calibration",
    "bn_eps", "joint_limits_min", "joint_limits_max", "calibration_min", "calibration_max",
})


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


def _glove_description_cells(text: str, glove: str, what: str, err: type) -> int:
    """The number of cells of a glove description (JSON text); checks that its id is `glove`.

    Only what the model file needs is checked (a JSON object, `id`, a non-empty `cells` list);
    the full rules are grid::GloveDescription's (weights_format.md, "Glove description files").
    """
    try:
        desc = json.loads(text)
    except json.JSONDecodeError as e:
        raise err(f"{what}glove_description is not valid JSON ({e}), expected a glove description object")
    if not isinstance(desc, dict) or desc.get("format") != "glovepose-glove":
        raise err(f"{what}glove_description is not a glove description (format 'glovepose-glove')")
    cells = desc.get("cells")
    if not isinstance(cells, list) or not cells:
        raise err(f"{what}glove_description has no 'cells' list, expected at least one cell")
    if desc.get("id") != glove:
        raise err(f"{what}glove_description has id {desc.get('id')!r} but glove is {glove!r}, expected the same id")
    return len(cells)


def _glove_description_extra_inputs(text: str) -> int:
    """The number of extra inputs (cells {"name", "extra": true}, not on the stretch maps) of a glove
    description already checked by _glove_description_cells."""
    return sum(1 for c in json.loads(text)["cells"] if isinstance(c, dict) and c.get("extra") is True)


def _check_unet_extra_inputs(extra_inputs: int, description: Optional[str], glove: str, what: str, err: type) -> None:
    """Raises `err` unless a U-Net reading `extra_inputs` extra planes fits its glove: the glove
    description's number of extra inputs, or 0 for the built-in glove (which has none)."""
    if description is not None:
        want = _glove_description_extra_inputs(description)
        if extra_inputs != want:
            raise err(f"{what}the U-Net reads {extra_inputs} extra input plane(s) (enc1.weight [w, {2 + extra_inputs}, 5, 5]) but the "
                      f"glove description has {want} extra input(s), expected the same number")
    elif glove == DEFAULT_GLOVE and extra_inputs != 0:
        raise err(f"{what}the U-Net reads {extra_inputs} extra input plane(s) (enc1.weight [w, {2 + extra_inputs}, 5, 5]) but the "
                  f"built-in glove {DEFAULT_GLOVE!r} has 0 extra inputs, expected enc1.weight [w, 2, 5, 5] (or give a glove_description)")


def model_tensors(model: nn.Module) -> Dict[str, torch.Tensor]:
    """The tensors a model file stores: the state_dict without `num_batches_tracked`."""
    return {k: v.detach().clone() for k, v in model.state_dict().items() if not k.endswith("num_batches_tracked")}


def architecture_of(model: nn.Module) -> Tuple[str, Optional[int], Optional[int]]:
    """(architecture, width, inputs) of a module a model file can hold.

    UNet -> ('unet', width, None: the U-Net does not know its glove's cell count; its number of
    extra inputs is model.extra_inputs, stored only as enc1.weight's shape [w, 2 + E, 5, 5]);
    FCN -> ('fcn', hidden, inputs); torch.nn.Linear(inputs, 25) -> ('linear', None, inputs).
    Raises TypeError for other modules, ValueError for an FCN or Linear without 25 outputs, a
    Linear without bias or a UNet whose enc1 does not read 2 + extra_inputs planes.
    """
    if isinstance(model, UNet):
        if model.enc1.in_channels != 2 + model.extra_inputs:
            raise ValueError(f"UNet with extra_inputs {model.extra_inputs} has enc1 reading {model.enc1.in_channels} planes, "
                             f"expected {2 + model.extra_inputs}")
        return "unet", int(model.width), None
    if isinstance(model, FCN):
        if model.fc6.out_features != DOF_COUNT:
            raise ValueError(f"FCN has {model.fc6.out_features} outputs, expected {DOF_COUNT} (one per DoF)")
        return "fcn", int(model.fc1.out_features), int(model.fc1.in_features)
    if isinstance(model, nn.Linear):
        if model.out_features != DOF_COUNT:
            raise ValueError(f"Linear has {model.out_features} outputs, expected {DOF_COUNT} (one per DoF)")
        if model.bias is None:
            raise ValueError("Linear has no bias, expected torch.nn.Linear(inputs, 25) with bias")
        return "linear", None, int(model.in_features)
    raise TypeError(f"cannot export a {type(model).__name__}, expected glovepose_ref.UNet, glovepose_ref.FCN or torch.nn.Linear")


def model_metadata(
    width: Optional[int],
    glove: str = DEFAULT_GLOVE,
    joint_limits_min: Optional[Sequence[float]] = None,
    joint_limits_max: Optional[Sequence[float]] = None,
    calibration_min: Optional[Sequence[float]] = None,
    calibration_max: Optional[Sequence[float]] = None,
    *,
    architecture: str = ARCHITECTURE,
    inputs: Optional[int] = None,
    calibration: Optional[str] = None,
    glove_description: Optional[Union[str, Mapping]] = None,
) -> Dict[str, str]:
    """The metadata dict of a model file; joint limits default to the reference hand model's.

    width: U-Net base width or FCN hidden width; must be None for `linear`.
    inputs: cells per frame; written when given (readers default to 44). With a glove_description
    (JSON text or a dict) and no inputs, inputs is the description's cell count.
    calibration: 'none', 'training' or 'onthefly'; written when given (readers default to
    'onthefly'); 'training' needs calibration_min/max. calibration_min/max: one value per input.
    """
    if architecture not in ARCHITECTURES:
        raise ValueError(f"architecture {architecture!r}, expected one of {list(ARCHITECTURES)}")
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
        "architecture": architecture,
    }
    if architecture == "linear":
        if width is not None:
            raise ValueError(f"width {width} given for a linear model, expected None (linear models have no width)")
    else:
        if width is None or int(width) < (2 if architecture == "fcn" else 1):
            raise ValueError(f"width {width} for architecture {architecture!r}, expected an integer >= {2 if architecture == 'fcn' else 1}")
        meta["width"] = str(int(width))
    desc_text: Optional[str] = None
    if glove_description is not None:
        desc_text = glove_description if isinstance(glove_description, str) else json.dumps(glove_description)
        cells = _glove_description_cells(desc_text, glove, "", ValueError)
        if inputs is None:
            inputs = cells
        elif int(inputs) != cells:
            raise ValueError(f"inputs {inputs} but the glove description has {cells} cells, expected the same")
    elif glove == DEFAULT_GLOVE and inputs is not None and int(inputs) != DEFAULT_GLOVE_CELLS:
        raise ValueError(f"inputs {inputs} for the built-in glove {DEFAULT_GLOVE!r}, expected {DEFAULT_GLOVE_CELLS} (or give a glove_description)")
    if inputs is not None:
        if int(inputs) < 1:
            raise ValueError(f"inputs {inputs}, expected >= 1")
        meta["inputs"] = str(int(inputs))
    meta["glove"] = glove
    if desc_text is not None:
        meta["glove_description"] = desc_text
    if calibration is not None:
        if calibration not in CALIBRATIONS:
            raise ValueError(f"calibration {calibration!r}, expected one of {list(CALIBRATIONS)}")
        if calibration == "training" and calibration_min is None:
            raise ValueError("calibration 'training' needs calibration_min and calibration_max (the training-set range)")
        meta["calibration"] = calibration
    meta["bn_eps"] = "1e-05"
    meta["joint_limits_min"] = lo_s
    meta["joint_limits_max"] = hi_s
    if (calibration_min is None) != (calibration_max is None):
        raise ValueError("calibration_min and calibration_max must be given together")
    if calibration_min is not None and calibration_max is not None:
        n = DEFAULT_GLOVE_CELLS if inputs is None else int(inputs)
        meta["calibration_min"] = _float_array(calibration_min, "calibration_min", n)
        meta["calibration_max"] = _float_array(calibration_max, "calibration_max", n)
    return meta


def export_model(
    model: ModelModule,
    path: PathLike,
    glove: str = DEFAULT_GLOVE,
    joint_limits_min: Optional[Sequence[float]] = None,
    joint_limits_max: Optional[Sequence[float]] = None,
    calibration_min: Optional[Sequence[float]] = None,
    calibration_max: Optional[Sequence[float]] = None,
    dtype: str = "F32",
    *,
    inputs: Optional[int] = None,
    calibration: Optional[str] = None,
    glove_description: Optional[Union[str, Mapping]] = None,
    extra_metadata: Optional[Mapping[str, str]] = None,
) -> None:
    """Writes `model` (a UNet, an FCN, or a torch.nn.Linear(inputs, 25)) to `path` as a model file.

    The architecture, width (U-Net, FCN) and inputs (FCN, Linear: from the module; U-Net: the
    `inputs` argument or the glove description's cell count, omitted otherwise) go into the
    metadata; see model_metadata for the other arguments. A U-Net's extra_inputs must equal the glove
    description's number of extra inputs (0 for the built-in glove); it is stored as enc1.weight's
    shape. dtype: 'F32' (default; models are trained in F32), 'F16' or 'BF16' (values rounded on write). extra_metadata: further string entries
    (provenance such as `training_command`); the format's own keys are refused.
    Raises ValueError for non-finite weights or bad metadata, TypeError for another module type.
    """
    if dtype not in _SAVE_DTYPES:
        raise ValueError(f"dtype {dtype!r}, expected one of {sorted(_SAVE_DTYPES)}")
    architecture, width, module_inputs = architecture_of(model)
    if module_inputs is not None:
        if inputs is not None and int(inputs) != module_inputs:
            raise ValueError(f"inputs {inputs}, but the {architecture} model takes {module_inputs} inputs")
        inputs = module_inputs
    for m in model.modules():
        if isinstance(m, torch.nn.BatchNorm2d) and m.eps != 1e-5:
            raise ValueError(f"BatchNorm eps {m.eps}, the format fixes bn_eps = 1e-05")
    tensors = {k: v.to(_SAVE_DTYPES[dtype]) for k, v in model_tensors(model).items()}
    for k, v in tensors.items():
        if not torch.isfinite(v).all():
            raise ValueError(f"tensor '{k}' has non-finite values (after conversion to {dtype})")
    meta: Dict[str, str] = {}
    for k, v in (extra_metadata or {}).items():
        if not isinstance(k, str) or not isinstance(v, str):
            raise ValueError(f"extra_metadata must map strings to strings, got {k!r}: {v!r}")
        if k in _FORMAT_KEYS:
            raise ValueError(f"extra_metadata key {k!r} is one export_model writes itself")
        meta[k] = v
    meta.update(model_metadata(
        width, glove, joint_limits_min, joint_limits_max, calibration_min, calibration_max,
        architecture=architecture, inputs=inputs, calibration=calibration, glove_description=glove_description,
    ))
    if isinstance(model, UNet):
        _check_unet_extra_inputs(model.extra_inputs, meta.get("glove_description"), glove, "", ValueError)
    safetensors_io.save(path, tensors, meta)


@dataclass(frozen=True)
class ModelInfo:
    """The parsed metadata of a model file (model::ModelInfo on the C++ side)."""

    architecture: str                      #: 'unet', 'fcn' or 'linear'
    width: int                             #: U-Net base width, FCN hidden width; 0 for linear
    inputs: int                            #: cells per frame (default 44)
    glove: str                             #: glove id
    glove_description: Optional[str]       #: the glove as JSON text, None for the built-in glove
    calibration: str                       #: 'none', 'training' or 'onthefly' (default)
    bn_eps: float
    joint_limits_min: Tuple[float, ...]    #: 25 values, radians, hand::kDofs order
    joint_limits_max: Tuple[float, ...]
    calibration_min: Optional[Tuple[float, ...]] = None  #: one per input, or None
    calibration_max: Optional[Tuple[float, ...]] = None
    metadata: Dict[str, str] = field(default_factory=dict)  #: every entry of the file, provenance included
    #: The glove's inputs not on the stretch maps (the description's "extra" cells; 0 for the built-in
    #: glove). A U-Net reads 2 + extra_inputs planes; import_model_with_info takes a U-Net's from
    #: enc1.weight's shape (no metadata key), checked against the description when there is one.
    extra_inputs: int = 0

    def denormalize(self, normalized: torch.Tensor) -> torch.Tensor:
        """Normalised DoFs [..., 25] (hand::kDofs order, -1 = min, +1 = max) -> radians, float64.

        As hand::JointLimits::denormalize: min + 0.5 * (n + 1) * (max - min), nothing clamped.
        """
        n = torch.as_tensor(normalized).to(torch.float64)
        if n.shape[-1:] != (DOF_COUNT,):
            raise ValueError(f"normalized has shape {list(n.shape)}, expected [..., {DOF_COUNT}]")
        lo = torch.tensor(self.joint_limits_min, dtype=torch.float64)
        hi = torch.tensor(self.joint_limits_max, dtype=torch.float64)
        return lo + 0.5 * (n + 1.0) * (hi - lo)


def parse_metadata(meta: Mapping[str, str], source: str = "<model>") -> ModelInfo:
    """Validates a model file's metadata (the rules of model::ModelInfo::from, plus the consistency of
    inputs with the glove and of the calibration range with inputs); returns it parsed.
    Raises ModelFileError naming the key.
    """
    def need(key: str) -> str:
        if key not in meta:
            raise ModelFileError(f"{source}: metadata key '{key}' is missing")
        return meta[key]

    def integer(key: str, least: int) -> int:
        text = need(key)
        try:
            v = int(text)
        except ValueError:
            raise ModelFileError(f"{source}: metadata {key} = {text!r}, expected an integer")
        if v < least:
            raise ModelFileError(f"{source}: metadata {key} = {v}, expected >= {least}")
        return v

    def numbers(key: str, length: Optional[int]) -> Tuple[float, ...]:
        try:
            vals = json.loads(need(key))
        except json.JSONDecodeError:
            vals = None
        if not isinstance(vals, list) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in vals
        ):
            raise ModelFileError(f"{source}: metadata {key} is not a JSON array of finite numbers")
        if length is not None and len(vals) != length:
            raise ModelFileError(f"{source}: metadata {key} holds {len(vals)} numbers, expected {length}")
        return tuple(float(v) for v in vals)

    for key, want in (("format", FORMAT), ("format_version", FORMAT_VERSION)):
        if need(key) != want:
            raise ModelFileError(f"{source}: metadata {key} = {meta[key]!r}, expected {want!r}")
    architecture = need("architecture")
    if architecture not in ARCHITECTURES:
        raise ModelFileError(f"{source}: metadata architecture = {architecture!r}, expected one of {list(ARCHITECTURES)}")
    # As the C++ reader: width is ignored for linear models.
    width = 0 if architecture == "linear" else integer("width", 2 if architecture == "fcn" else 1)
    inputs = integer("inputs", 1) if "inputs" in meta else DEFAULT_GLOVE_CELLS
    glove = need("glove")
    desc = meta.get("glove_description")
    extra_inputs = 0
    if desc is not None:
        cells = _glove_description_cells(desc, glove, f"{source}: metadata ", ModelFileError)
        if cells != inputs:
            raise ModelFileError(f"{source}: metadata inputs = {inputs} but the glove description has {cells} cells")
        extra_inputs = _glove_description_extra_inputs(desc)
    elif glove == DEFAULT_GLOVE and inputs != DEFAULT_GLOVE_CELLS:
        raise ModelFileError(f"{source}: metadata inputs = {inputs} for the built-in glove {DEFAULT_GLOVE!r}, expected {DEFAULT_GLOVE_CELLS}")
    calibration = meta.get("calibration", "onthefly")
    if calibration not in CALIBRATIONS:
        raise ModelFileError(f"{source}: metadata calibration = {calibration!r}, expected one of {list(CALIBRATIONS)}")
    try:
        bn_eps = float(need("bn_eps"))
    except ValueError:
        bn_eps = float("nan")
    if not (math.isfinite(bn_eps) and bn_eps > 0):
        raise ModelFileError(f"{source}: metadata bn_eps = {meta['bn_eps']!r}, expected a positive number")
    if architecture == "unet" and bn_eps != 1e-5:
        raise ModelFileError(f"{source}: metadata bn_eps = {meta['bn_eps']!r}, expected '1e-05'")
    lo = numbers("joint_limits_min", DOF_COUNT)
    hi = numbers("joint_limits_max", DOF_COUNT)
    for i, (a, b) in enumerate(zip(lo, hi)):
        if not a < b:
            raise ModelFileError(f"{source}: joint limits of DoF {i} (theta {9 + i}): min {a} is not below max {b}")
    cmin = cmax = None
    if "calibration_min" in meta or "calibration_max" in meta:
        cmin = numbers("calibration_min", inputs)
        cmax = numbers("calibration_max", inputs)
    if calibration == "training" and cmin is None:
        raise ModelFileError(f"{source}: metadata calibration = 'training' but calibration_min/max are missing")
    return ModelInfo(
        architecture=architecture, width=width, inputs=inputs, glove=glove, glove_description=desc,
        calibration=calibration, bn_eps=bn_eps, joint_limits_min=lo, joint_limits_max=hi,
        calibration_min=cmin, calibration_max=cmax, metadata=dict(meta), extra_inputs=extra_inputs,
    )


def check_metadata(meta: Mapping[str, str], source: str = "<model>") -> int:
    """Validates a model file's metadata; returns the width (0 for a linear model). See parse_metadata."""
    return parse_metadata(meta, source).width


def make_module(info: ModelInfo) -> ModelModule:
    """A module of the architecture and sizes `info` names, with PyTorch's default initialisation
    (a U-Net reads 2 + info.extra_inputs input planes)."""
    if info.architecture == "unet":
        return UNet(info.width, info.extra_inputs)
    if info.architecture == "fcn":
        return FCN(info.inputs, info.width, DOF_COUNT)
    return nn.Linear(info.inputs, DOF_COUNT)


def import_model_with_info(path: PathLike) -> Tuple[ModelModule, ModelInfo]:
    """Loads a model file of any architecture: (module in eval mode, its parsed metadata).

    The module is a UNet, an FCN (outputs: normalised DoFs in hand::kDofs order) or a
    torch.nn.Linear(inputs, 25), loaded strictly (no tensor missing or extra, shapes equal,
    dtype F32/F16/BF16 widened to float32, all finite). A U-Net's extra inputs E come from
    enc1.weight's shape [w, 2 + E, 5, 5]; with a glove description in the file E must equal its
    number of extra inputs (without one: 0 for the built-in glove, any E >= 0 for another glove id),
    and info.extra_inputs is E. Raises ModelFileError on bad metadata, names, shapes, dtypes,
    non-finite values or such a mismatch.
    """
    tensors, meta = safetensors_io.load(path)
    info = parse_metadata(meta, str(path))
    if info.architecture == "unet":
        enc1 = tensors.get("enc1.weight")
        # A missing or malformed enc1.weight is left to the strict checks below (E as the metadata implies).
        if enc1 is not None and enc1.dim() == 4 and enc1.shape[1] >= 2:
            extra_inputs = int(enc1.shape[1]) - 2
            _check_unet_extra_inputs(extra_inputs, info.glove_description, info.glove, f"{path}: ", ModelFileError)
            info = dataclasses.replace(info, extra_inputs=extra_inputs)
    model = make_module(info)
    expected = model_tensors(model)
    missing = sorted(set(expected) - set(tensors))
    extra = sorted(set(tensors) - set(expected))
    if missing or extra:
        raise ModelFileError(f"{path}: {info.architecture} model: tensors missing {missing}, unexpected {extra}")
    sd = {}
    for k, ref in expected.items():
        t = tensors[k]
        if tuple(t.shape) != tuple(ref.shape):
            raise ModelFileError(f"{path}: tensor '{k}' has shape {list(t.shape)}, expected {list(ref.shape)}")
        if t.dtype not in _SAVE_DTYPES.values():
            raise ModelFileError(f"{path}: tensor '{k}' has dtype {safetensors_io.dtype_name(t.dtype)}, expected F32, F16 or BF16")
        t = t.to(torch.float32)
        if not torch.isfinite(t).all():
            raise ModelFileError(f"{path}: tensor '{k}' has non-finite values")
        sd[k] = t
    for k, v in model.state_dict().items():
        if k.endswith("num_batches_tracked"):
            sd[k] = torch.zeros_like(v)
    model.load_state_dict(sd, strict=True)
    model.eval()
    return model, info


def import_model(path: PathLike) -> ModelModule:
    """Loads a model file into a UNet, FCN or torch.nn.Linear(inputs, 25) in eval mode.

    Strict: no tensor missing or extra, shapes equal; 16-bit tensors are widened to float32.
    Raises ModelFileError on bad metadata, names, shapes or non-finite values.
    Use import_model_with_info for the metadata (joint limits, calibration, provenance).
    """
    return import_model_with_info(path)[0]
