#!/usr/bin/env python3
"""Trains one of the paper's networks of Sec. 5.4 (FCN, LSTM, ResNet, U-Net, CGAN) with PyTorch on
a dataset file and scores it on held-out runs: the columns of Tables 4 and 5 that glovepose does
not run at run time (run.sh table45 with TABLE45_TORCH). Samples, calibration, targets, the loss
mask and the kept epoch are train_torch.py's (the C++ trainer's); the score is `glovepose eval`'s
mean absolute angle error over the labelled DoFs, against the labels and, for simulated data,
against the true angles. It writes a JSON with eval's keys (mean_deg, vs_labels, vs_truth).

    torch_networks.py --data corpus.safetensors --model lstm:490 --subjects 0 --gloves 0 --sessions 0-3 \\
        --eval-subjects 0 --eval-sessions 4 --batch 256 --epochs 4 --json s0_inter_lstm.json
    torch_networks.py --data corpus.safetensors --check-model m.safetensors --eval-subjects 0 --gloves 0 --json check.json

--model KIND:WIDTH, or KIND@PARAMS (e.g. resnet@2989249: the width whose parameter count comes
closest, glovepose_ref.paper_networks.sized). The paper's optimisers are used where the budget
allows them (Adam lr 2e-4, betas 0.5 / 0.999, for every network here: the paper's SGD for the FCN
and LSTM needs far more epochs than a CPU run has). LSTM: a window of 5 frames (the paper's). CGAN:
the U-Net as generator, the paper's C64-C128-C256-C512-C1 discriminator on the stretch maps and a
pose map, pix2pix's loss (adversarial + 100 x L1). --check-model evaluates a glovepose model file
(U-Net, FCN or linear) with the same scoring, to check it against `glovepose eval`.

Needs Debian's python3-torch and python3-numpy (/usr/bin/python3); downloads nothing.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import torch
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

from glovepose_ref import import_model, safetensors_io, use_fast_transposed_convolution  # noqa: E402
from glovepose_ref.export import JOINT_LIMITS_MAX, JOINT_LIMITS_MIN  # noqa: E402
from glovepose_ref.glove import glove_settings, glove_tables  # noqa: E402
from glovepose_ref.whole_file import write_whole  # noqa: E402
from glovepose_ref.paper_networks import PatchDiscriminator, build, parameters, sized  # noqa: E402
from glovepose_ref.model import UNet  # noqa: E402
from train_torch import Pipeline, id_list, initialize, make_samples, mean_error_deg, predict_radians  # noqa: E402

LSTM_WINDOW = 5  # frames (appendix A)
L1_WEIGHT = 100.0  # pix2pix's weight of the L1 term of the CGAN's generator loss


def die(message: str) -> None:
    sys.exit(f"torch_networks: {message}")


def parse_model(text: str, inputs: int):
    kind, sep, size = text.partition(":")
    if not sep:
        kind, sep, size = text.partition("@")
        if sep and size.isdigit():
            return kind, sized(kind, float(size), inputs)
    if not sep or not size.isdigit() or int(size) < 2 or kind not in ("fcn", "lstm", "resnet", "unet", "cgan"):
        die(f"--model {text!r}, expected fcn|lstm|resnet|unet|cgan followed by :WIDTH or @PARAMETERS")
    return kind, int(size)


def train(model: Pipeline, kind: str, samples: dict, validation: dict, labelled: torch.Tensor, settings: dict, args) -> dict:
    """Trains in place; keeps the epoch of the lowest validation error. Returns what was kept."""
    optimizer = torch.optim.Adam(model.parameters(), lr=args.lr, betas=(0.5, 0.999))
    discriminator = None
    if kind == "cgan":
        discriminator = PatchDiscriminator(64, model.network.enc1.in_channels + 1)
        initialize(discriminator, args.seed + 1)
        d_optimizer = torch.optim.Adam(discriminator.parameters(), lr=args.lr, betas=(0.5, 0.999))
        bce = nn.BCEWithLogitsLoss()
        covered = torch.zeros(25)
        covered[model.dof_index] = 1.0  # pose-map slots that hold a DoF; the others are not compared
        covered = covered.view(1, 1, 5, 5)
    frames = samples["inputs"].shape[0]
    steps = frames // args.batch
    if steps < 1:
        die(f"{frames} training frames, fewer than one batch of {args.batch}")
    best, best_error, best_epoch = None, math.inf, -1
    start = time.time()
    for epoch in range(args.epochs):
        order = torch.randperm(frames, generator=torch.Generator().manual_seed(args.seed * 1000003 + epoch))
        loss_sum = 0.0
        for step in range(steps):
            batch = order[step * args.batch:(step + 1) * args.batch]
            x, t = samples["inputs"][batch], samples["targets"][batch]
            if discriminator is None:
                loss = ((model(x) - t)[:, labelled] ** 2).mean()
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
            else:
                planes = model.planes(x)
                fake = model.network(planes)
                real = torch.zeros(len(batch), 25)
                real[:, model.dof_index] = t
                real = real.view(-1, 1, 5, 5)
                d_real, d_fake = discriminator(planes, real), discriminator(planes, (fake * covered).detach())
                d_loss = 0.5 * (bce(d_real, torch.ones_like(d_real)) + bce(d_fake, torch.zeros_like(d_fake)))
                d_optimizer.zero_grad()
                d_loss.backward()
                d_optimizer.step()
                d_fake = discriminator(planes, fake * covered)
                l1 = (model.readout(fake) - t)[:, labelled].abs().mean()
                loss = bce(d_fake, torch.ones_like(d_fake)) + L1_WEIGHT * l1
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
            loss_sum += float(loss)
        error = mean_error_deg(model, validation, labelled, "cpu", settings) if validation["inputs"].shape[0] else math.nan
        print(f"epoch {epoch + 1}/{args.epochs}: loss {loss_sum / steps:.5f}, validation error {error:.3f} deg, "
              f"{(epoch + 1) * steps * args.batch / (time.time() - start):.0f} samples/s", flush=True)
        if not error >= best_error:
            best_error, best_epoch = error, epoch
            best = {k: v.detach().clone() for k, v in model.state_dict().items()}
    model.load_state_dict(best)
    return {"best_epoch": best_epoch + 1, "validation_error_deg": round(best_error, 6), "train_seconds": round(time.time() - start, 1)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="dataset file (weights_format.md)")
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--model", help="KIND:WIDTH or KIND@PARAMETERS, KIND fcn|lstm|resnet|unet|cgan")
    what.add_argument("--check-model", help="a glovepose model file to score (no training)")
    parser.add_argument("--subjects", type=id_list, help="training subjects (default: all but --exclude-subjects)")
    parser.add_argument("--exclude-subjects", type=id_list, default=[], help="subjects left out of training")
    parser.add_argument("--sessions", type=id_list, help="training sessions (default: all)")
    parser.add_argument("--gloves", type=id_list, help="gloves of training and scoring (default: all)")
    parser.add_argument("--stride", type=int, default=1, help="every STRIDE-th training frame of a run")
    parser.add_argument("--eval-subjects", type=id_list, required=True, help="scored subjects")
    parser.add_argument("--eval-sessions", type=id_list, help="scored sessions (default: all)")
    parser.add_argument("--epochs", type=int, default=4)
    parser.add_argument("--batch", type=int, default=1024)
    parser.add_argument("--lr", type=float, default=2e-4)
    parser.add_argument("--validation", type=float, default=0.1)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--threads", type=int, default=0, help="PyTorch threads (0: its default)")
    parser.add_argument("--json", required=True, help="result file")
    args = parser.parse_args()
    if args.threads > 0:
        torch.set_num_threads(args.threads)
    use_fast_transposed_convolution()
    if args.stride < 1:
        die(f"--stride {args.stride}, expected >= 1")

    tensors, meta = safetensors_io.load(args.data)
    if meta.get("format") != "glovepose-dataset":
        die(f"'{args.data}' is not a glovepose dataset file (format {meta.get('format')!r})")
    glove_id = meta.get("glove_layout", "")
    cell_slots, dof_slots = glove_tables(glove_id, None)
    settings = glove_settings(None, JOINT_LIMITS_MIN, JOINT_LIMITS_MAX)
    truth = "true_angles" in tensors
    result = {"trained_with": "PyTorch " + torch.__version__, "command": "torch_networks.py " + " ".join(sys.argv[1:])}

    if args.check_model:
        model = import_model(args.check_model)
        history = 1
        model = Pipeline(model, cell_slots, dof_slots) if isinstance(model, UNet) else model
    else:
        kind, width = parse_model(args.model, len(cell_slots))
        history = LSTM_WINDOW if kind == "lstm" else 1
        network = build(kind, width, len(cell_slots))
        model = Pipeline(network, cell_slots, dof_slots)
        initialize(model, args.seed)
        result.update(architecture=kind, width=width, parameters=parameters(network))
        everyone = sorted(set(tensors["subject"].unique().tolist()))
        subjects = sorted(set(args.subjects or everyone) - set(args.exclude_subjects))
        samples, validation, labelled = make_samples(tensors, meta, subjects, "onthefly", args.validation, settings,
                                                     gloves=args.gloves, sessions=args.sessions, stride=args.stride, history=history)
        print(f"{kind}:{width} ({parameters(network) / 1e6:.2f}M parameters): {samples['inputs'].shape[0]} training frames, "
              f"{validation['inputs'].shape[0]} validation frames", flush=True)
        result.update(train(model, kind, samples, validation, labelled, settings, args))
        del samples, validation

    scored, _, labelled = make_samples(tensors, meta, args.eval_subjects, "onthefly", 0.0, settings, gloves=args.gloves,
                                       sessions=args.eval_sessions, history=history, truth=truth)
    result["frames"] = int(scored["inputs"].shape[0])
    radians = predict_radians(model, scored["inputs"], "cpu", settings)
    result["vs_labels"] = {"mean_deg": round(mean_error_deg(model, scored, labelled, "cpu", settings, radians), 6)}
    result["mean_deg"] = result["vs_labels"]["mean_deg"]
    if truth:
        behind = dict(scored, angles=scored["true_angles"])
        result["vs_truth"] = {"mean_deg": round(mean_error_deg(model, behind, labelled, "cpu", settings, radians), 6)}
    else:
        result["vs_truth"] = None
    write_whole(args.json, json.dumps(result, indent=1) + "\n")
    print(f"scored {result['frames']} frames: {result['mean_deg']:.3f} deg vs labels"
          + (f", {result['vs_truth']['mean_deg']:.3f} deg vs truth" if truth else "") + f"; wrote {args.json}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
