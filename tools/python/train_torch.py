#!/usr/bin/env python3
"""Trains glovepose's networks with PyTorch, on one process or many: the path for users who outgrow
one machine. The C++ trainer (`glovepose train`) stays the default on one machine; this script reads
the same dataset files, prepares the same samples and writes a model file glovepose loads.

    /usr/bin/python3 tools/python/train_torch.py --data corpus.safetensors --model unet:64 --out m.safetensors
    torchrun --nproc_per_node=2 tools/python/train_torch.py --data corpus.safetensors --model unet:64 --out m.safetensors
    torchrun --nnodes=4 --nproc_per_node=8 --rdzv_backend=c10d --rdzv_endpoint=HOST:29400 tools/python/train_torch.py ...

Under torchrun every process takes an equal share of each global batch (--batch is the global batch)
through DistributedDataParallel: gloo on CPUs, NCCL on GPUs (--device cuda: one GPU per local rank).
Debian 12's torchrun (torch 1.13 under Python 3.11) fails on its own default --redirects/--tee
values ("'NoneType' object has no attribute 'get'"); give them: --redirects 1 --tee 1 --log_dir DIR.

Samples as the C++ trainer prepares them (train/samples.hpp): recording frames that are not collision
outliers, of the selected subjects; inputs calibrated per run (subject, glove, session) on the fly
from its calibration frames (min and max of the running median over the glove's median_seconds at
the dataset's frame rate, 20 frames at 60 Hz by default; a sensor flat by the glove's rule read as 0;
values clamped to +-1.5), or not at all (--calibration none); targets the angles normalised by the
glove's joint limits (its description's, else the reference's), the rest pose (0 rad clamped into the limits) for DoFs the data does not
label (metadata labelled_dofs), whose loss is masked out. The last --validation fraction of every
run validates; the model with the lowest validation error (mean absolute angle error over the
labelled DoFs) is kept. Same architectures and initialisation (Xavier uniform, zero biases), the
same L2 loss and the paper's Adam (lr 2e-4, betas 0.5 / 0.999).

Needs Debian's python3-torch and python3-numpy (/usr/bin/python3); downloads nothing.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch
import torch.distributed as dist
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parent))

from glovepose_ref import FCN, UNet, export_model, safetensors_io, use_fast_transposed_convolution  # noqa: E402
from glovepose_ref.export import JOINT_LIMITS_MAX, JOINT_LIMITS_MIN  # noqa: E402
from glovepose_ref.glove import DOF_NAMES, glove_settings, glove_tables, median_frames  # noqa: E402

CLAMP = 1.5
MIN_RANGE_TO_NOISE = 12.0  # sensor::CalibrationConfig::min_range_to_noise
NOISE_GAUSSIAN_SCALE = 0.465  # sensor::NoiseEstimator: its statistic for white noise of SD 1


def id_list(text: str) -> list:
    ids = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        ids += list(range(int(lo), int(hi or lo) + 1))
    return ids


def _median3(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    return np.maximum(np.minimum(a, b), np.minimum(np.maximum(a, b), c))


def noise_sd(frames: np.ndarray) -> np.ndarray:
    """Per-sensor noise SD of frames in time order (sensor::NoiseEstimator): the mean over time of the
    median of three consecutive |x - median3(x)| residuals, divided by its value for unit white
    Gaussian noise (0.465); 0 with fewer than 5 frames."""
    if len(frames) < 5:
        return np.zeros(frames.shape[1])
    r = np.abs(frames[1:-1] - _median3(frames[:-2], frames[1:-1], frames[2:]))
    return _median3(r[:-2], r[1:-1], r[2:]).mean(axis=0) / NOISE_GAUSSIAN_SCALE


def onthefly_range(calibration: np.ndarray, window: int):
    """min, max and noise SD of the running median of `window` frames (sensor/calibration.hpp; the
    noise as sensor::OnTheFlyCalibrator's: noise_sd x median_noise_factor(window))."""
    frames = calibration.astype(np.float64)
    windows = np.lib.stride_tricks.sliding_window_view(frames, window, axis=0)
    medians = np.median(windows, axis=-1)
    factor = math.sqrt(math.pi / (2.0 * window + math.pi - 2.0))
    return medians.min(axis=0), medians.max(axis=0), noise_sd(frames) * factor


def normalize(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, flat_range: float, noise: np.ndarray | None = None) -> np.ndarray:
    """Cells -> [-1, 1] by the range, clamped to +-CLAMP; flat sensors read 0, and with `noise` (the
    range's noise SD) also noise-only ones, as sensor::CalibrationRange does."""
    span = hi - lo
    flat = (span <= flat_range * np.maximum(np.abs(lo), np.abs(hi))) | (span <= 0)
    if noise is not None:
        flat |= (noise > 0) & (span < MIN_RANGE_TO_NOISE * noise)
    out = np.clip(2.0 * (x - lo) / np.where(flat, 1.0, span) - 1.0, -CLAMP, CLAMP)
    out[:, flat] = 0.0
    return out


def make_samples(data: dict, meta: dict, subjects, calibration: str, validation: float, settings: dict,
                 gloves=None, sessions=None, stride: int = 1, history: int = 1, truth: bool = False,
                 noise_only: bool = False, outliers: bool = False):
    """(train, validation) dicts of inputs, targets (normalised), angles (radians), with the labelled mask.

    Runs of `subjects`, `gloves` and `sessions` (None: all); every `stride`-th kept frame of a run
    (train/samples.hpp). history > 1: each input is the window [N, history, cells] of the run's
    recording frames ending at the sample's frame (outliers included, the first frame repeated
    before the run starts), for networks that read time. truth: also "true_angles" (simulated data).
    noise_only: on-the-fly calibration also maps noise-only sensors to 0 (sensor::OnTheFlyCalibrator's
    rule: range below 12 x the noise SD of the median). outliers: keep the collision-outlier frames."""
    cells = data["cells"].numpy().astype(np.float64)
    angles = data["angles"].numpy().astype(np.float64)
    subject, glove, session = data["subject"].numpy(), data["glove"].numpy(), data["session"].numpy()
    kind, outlier = data["kind"].numpy(), data["outlier"].numpy()
    true_angles = data["true_angles"].numpy().astype(np.float64) if truth else None
    labelled = np.ones(25, dtype=bool)
    if "labelled_dofs" in meta:
        names = meta["labelled_dofs"].split(",")
        labelled = np.array([n in names for n in DOF_NAMES])
    lo_lim, hi_lim = np.array(settings["joint_limits_min"]), np.array(settings["joint_limits_max"])
    window = median_frames(settings["median_seconds"], float(meta["frame_rate"]))
    rest = np.clip(0.0, lo_lim, hi_lim)
    parts = {"train": [], "validation": []}
    for key in sorted(set(zip(subject.tolist(), glove.tolist(), session.tolist()))):
        if any(ids is not None and k not in ids for k, ids in zip(key, (subjects, gloves, sessions))):
            continue
        run = (subject == key[0]) & (glove == key[1]) & (session == key[2])
        recording = np.flatnonzero(run & (kind == 0))
        kept = np.flatnonzero(outliers | (outlier[recording] == 0))[::stride]  # positions within the recording
        if not len(kept):
            continue
        x = cells[recording]
        if calibration == "onthefly":
            calibration_frames = cells[run & (kind == 1)]
            if len(calibration_frames) < window:
                sys.exit(f"train_torch: subject {key[0]}, glove {key[1]}, session {key[2]} has {len(calibration_frames)} calibration frames, "
                         f"expected at least {window} for on-the-fly calibration")
            lo, hi, noise = onthefly_range(calibration_frames, window)
            x = normalize(x, lo, hi, settings["flat_relative_range"], noise if noise_only else None)
        x = x[np.maximum(kept[:, None] + np.arange(1 - history, 1), 0)] if history > 1 else x[kept]
        a = angles[recording[kept]]
        toward = np.where(labelled, a, rest)
        t = 2.0 * (toward - lo_lim) / (hi_lim - lo_lim) - 1.0
        cut = len(x) - math.floor(validation * len(x))
        q = true_angles[recording[kept]] if truth else a
        parts["train"].append((x[:cut], t[:cut], a[:cut], q[:cut]))
        parts["validation"].append((x[cut:], t[cut:], a[cut:], q[cut:]))
    if not parts["train"]:
        sys.exit("train_torch: no recording frame passes the selection")

    def stack(items):
        names = ("inputs", "targets", "angles") + (("true_angles",) if truth else ())
        return {name: torch.tensor(np.concatenate([i[k] for i in items]), dtype=torch.float32) for k, name in enumerate(names)}
    return stack(parts["train"]), stack(parts["validation"]), torch.tensor(labelled)


class Pipeline(nn.Module):
    """Calibrated cells -> the 25 normalised DoFs: the U-Net between the glove's input planes and
    pose map, or the FCN (which reads every input, extra ones included, as a vector).

    The U-Net's input (grid::GridMap::to_input_planes): the two stretch maps holding the cells on the
    maps at their slots (0 elsewhere), then one constant 5x5 plane per extra input (slot None), in
    input order, filled with that input's value: [N, 2 + E, 5, 5]."""

    def __init__(self, network: nn.Module, cell_slots, dof_slots):
        super().__init__()
        self.network = network
        self.unet = getattr(network, "reads_maps", False)  # the U-Net and the ResNet read stretch maps
        on_maps = [i for i, slot in enumerate(cell_slots) if slot is not None] if self.unet else []
        extra = [i for i, slot in enumerate(cell_slots) if slot is None] if self.unet else []
        if self.unet and len(extra) != network.extra_inputs:
            raise ValueError(f"the glove has {len(extra)} extra input(s), the U-Net reads {network.extra_inputs}")
        index = lambda values: torch.tensor(values, dtype=torch.long)  # noqa: E731
        self.register_buffer("map_inputs", index(on_maps), persistent=False)  # columns of the cells on the maps
        self.register_buffer("map_index", index([cell_slots[i][0] * 25 + cell_slots[i][1] * 5 + cell_slots[i][2] for i in on_maps]),
                             persistent=False)  # their slots in the flattened 2x5x5 maps
        self.register_buffer("extra_inputs", index(extra), persistent=False)  # columns of the extra inputs, in input order
        self.register_buffer("dof_index", index([r * 5 + c for r, c in dof_slots]), persistent=False)

    def forward(self, cells: torch.Tensor) -> torch.Tensor:
        if not self.unet:
            return self.network(cells)
        return self.readout(self.network(self.planes(cells)))

    def planes(self, cells: torch.Tensor) -> torch.Tensor:
        """[N, cells] -> the network's input planes [N, 2 + E, 5, 5]."""
        n = cells.shape[0]
        maps = torch.zeros(n, 50, dtype=cells.dtype, device=cells.device)
        maps[:, self.map_index] = cells[:, self.map_inputs]
        planes = maps.view(n, 2, 5, 5)
        if self.extra_inputs.numel():
            constant = cells[:, self.extra_inputs].view(n, -1, 1, 1).expand(n, self.extra_inputs.numel(), 5, 5)
            planes = torch.cat([planes, constant], 1)
        return planes

    def readout(self, pose_map: torch.Tensor) -> torch.Tensor:
        """[N, 1, 5, 5] pose map -> [N, 25] DoFs."""
        return pose_map.reshape(-1, 25)[:, self.dof_index]


def initialize(module: nn.Module, seed: int) -> None:
    """Xavier uniform weights, zero biases, BN scale 1 (the C++ trainers' initialisation)."""
    torch.manual_seed(seed)
    for m in module.modules():
        if isinstance(m, (nn.Conv2d, nn.ConvTranspose2d, nn.Linear)):
            nn.init.xavier_uniform_(m.weight)
            nn.init.zeros_(m.bias)
        elif isinstance(m, nn.BatchNorm2d):
            nn.init.ones_(m.weight)
            nn.init.zeros_(m.bias)


def predict_radians(model: nn.Module, inputs: torch.Tensor, device, settings: dict) -> torch.Tensor:
    """The model's angles (radians, float64) for calibrated inputs, in batches, in eval mode, held
    within the joint limits as glovepose holds them (so the validation error is `glovepose eval`'s)."""
    lo = torch.tensor(settings["joint_limits_min"], dtype=torch.float64)
    hi = torch.tensor(settings["joint_limits_max"], dtype=torch.float64)
    model.eval()
    with torch.no_grad():
        out = torch.cat([model(x.to(device)).cpu() for x in inputs.split(4096)]).double()
    model.train()
    return lo + 0.5 * (out.clamp(-1.0, 1.0) + 1.0) * (hi - lo)


def mean_error_deg(model: nn.Module, samples: dict, labelled: torch.Tensor, device, settings: dict, radians=None) -> float:
    """Mean absolute angle error over the labelled DoFs (`glovepose eval`'s mean_deg), in degrees."""
    if radians is None:
        radians = predict_radians(model, samples["inputs"], device, settings)
    errors = (radians - samples["angles"].double()).abs()[:, labelled]
    return float(errors.mean() * 180.0 / math.pi)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="dataset file (weights_format.md)")
    parser.add_argument("--model", required=True, help="unet:W or fcn:H")
    parser.add_argument("--out", required=True, help="model file to write (rank 0)")
    parser.add_argument("--glove", help="glove description JSON (default: the built-in 44-cell glove)")
    parser.add_argument("--subjects", type=id_list, help="subjects to train on, e.g. 0-3,7 (default: all)")
    parser.add_argument("--exclude-subjects", type=id_list, default=[], help="subjects left out, e.g. 9")
    parser.add_argument("--calibration", choices=("onthefly", "none"), default="onthefly")
    parser.add_argument("--epochs", type=int, default=10)
    parser.add_argument("--batch", type=int, default=1024, help="global batch (split between the processes)")
    parser.add_argument("--lr", type=float, default=2e-4)
    parser.add_argument("--validation", type=float, default=0.1)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--device", default="cpu", help="cpu or cuda")
    args = parser.parse_args()

    distributed = "WORLD_SIZE" in os.environ and int(os.environ["WORLD_SIZE"]) > 1
    rank, world = 0, 1
    device = torch.device(args.device)
    if distributed:
        dist.init_process_group(backend="nccl" if args.device == "cuda" else "gloo")
        rank, world = dist.get_rank(), dist.get_world_size()
        if args.device == "cuda":
            device = torch.device("cuda", int(os.environ.get("LOCAL_RANK", 0)))
            torch.cuda.set_device(device)
        torch.set_num_threads(max(1, (os.cpu_count() or 1) // int(os.environ.get("LOCAL_WORLD_SIZE", world))))
    use_fast_transposed_convolution()
    if args.batch % world:
        sys.exit(f"train_torch: --batch {args.batch} is not a multiple of the {world} processes")

    tensors, meta = safetensors_io.load(args.data)
    description = Path(args.glove).read_text() if args.glove else None
    if description is not None:  # the rate rule of glovepose train (tools/cli/train.cpp, glove_for)
        desc, rate = json.loads(description), float(meta["frame_rate"])
        if "rate_hz" in desc and abs(float(desc["rate_hz"]) - rate) > 1e-9 * rate:
            sys.exit(f"train_torch: the dataset's frame rate is {rate} Hz but the glove description's rate_hz is {desc['rate_hz']}, "
                     "expected the same rate")
        if "rate_hz" not in desc:  # the model's description carries the rate its calibration window was trained at
            desc["rate_hz"] = rate
            description = json.dumps(desc)
    glove_id = meta.get("glove_layout", "")
    cell_slots, dof_slots = glove_tables(glove_id, description)
    if len(cell_slots) != tensors["cells"].shape[1]:
        sys.exit(f"train_torch: the glove has {len(cell_slots)} cells, the dataset {tensors['cells'].shape[1]}")
    subjects = sorted(set(args.subjects if args.subjects else tensors["subject"].unique().tolist()) - set(args.exclude_subjects))
    settings = glove_settings(description, JOINT_LIMITS_MIN, JOINT_LIMITS_MAX)
    train, validation, labelled = make_samples(tensors, meta, subjects, args.calibration, args.validation, settings)

    kind, _, size = args.model.partition(":")
    if kind == "unet":  # extra inputs (not on the stretch maps) are read as one constant input plane each
        network = UNet(int(size or 64), extra_inputs=sum(slot is None for slot in cell_slots))
    elif kind == "fcn":
        network = FCN(len(cell_slots), int(size or 2048), 25)
    else:
        sys.exit(f"train_torch: --model {args.model!r}, expected unet:W or fcn:H")
    model = Pipeline(network, cell_slots, dof_slots)
    initialize(model, args.seed)
    model.to(device)
    trained = nn.parallel.DistributedDataParallel(model) if distributed else model
    optimizer = torch.optim.Adam(trained.parameters(), lr=args.lr, betas=(0.5, 0.999))

    frames = train["inputs"].shape[0]
    local = args.batch // world
    steps = frames // args.batch
    if steps < 1:
        sys.exit(f"train_torch: {frames} training frames, fewer than one batch of {args.batch}")
    mask = labelled.to(device)
    best, best_error, best_epoch = None, math.inf, -1
    start = time.time()
    for epoch in range(args.epochs):
        order = torch.randperm(frames, generator=torch.Generator().manual_seed(args.seed * 1000003 + epoch))  # the same on every rank
        loss_sum = 0.0
        for step in range(steps):
            batch = order[step * args.batch + rank * local: step * args.batch + (rank + 1) * local]
            x, t = train["inputs"][batch].to(device), train["targets"][batch].to(device)
            loss = ((trained(x) - t)[:, mask] ** 2).mean()
            optimizer.zero_grad()
            loss.backward()  # DDP averages the gradients over the processes
            optimizer.step()
            loss_sum += float(loss)
        if rank == 0:
            error = mean_error_deg(model, validation, labelled, device, settings) if validation["inputs"].shape[0] else math.nan
            print(f"epoch {epoch + 1}/{args.epochs}: loss {loss_sum / steps:.5f}, validation error {error:.3f} deg, "
                  f"{(epoch + 1) * steps * args.batch / (time.time() - start):.0f} samples/s on {world} process(es)", flush=True)
            if not error >= best_error:
                best_error, best_epoch = error, epoch
                best = {k: v.detach().cpu().clone() for k, v in model.network.state_dict().items()}
    if rank == 0:
        network.load_state_dict(best)
        network.to("cpu")
        extra = {"training_command": "train_torch.py " + " ".join(sys.argv[1:]), "training_seed": str(args.seed),
                 "training_processes": str(world), "best_epoch": str(best_epoch + 1), "validation_error_deg": f"{best_error:.6f}"}
        if not bool(labelled.all()):
            extra["labelled_dofs"] = ",".join(n for n, l in zip(DOF_NAMES, labelled.tolist()) if l)
        export_model(network, args.out, glove=glove_id, calibration=args.calibration, glove_description=description,
                     inputs=len(cell_slots), joint_limits_min=settings["joint_limits_min"],
                     joint_limits_max=settings["joint_limits_max"], extra_metadata=extra)
        print(f"done: {args.epochs} epochs x {steps} steps of {args.batch} on {world} process(es); kept epoch {best_epoch + 1}, "
              f"validation error {best_error:.3f} deg; wrote {args.out}", flush=True)
    if distributed:
        dist.destroy_process_group()
    return 0


if __name__ == "__main__":
    sys.exit(main())
