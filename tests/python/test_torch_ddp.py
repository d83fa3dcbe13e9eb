"""tools/python/train_torch.py under torchrun with two processes (DistributedDataParallel, gloo on the
CPU) trains a U-Net that glovepose loads, whose held-out error is within 10% of the C++ trainer's on
the same data, epochs and batch.

Data: a small simulated corpus (3 people, 2 sessions of 30 s, 10 s calibration each); both train a
U-Net w = 8 on people 0 and 1 for 20 epochs of batch 256; `glovepose eval` scores both on person 2.
Debian 12's torchrun (torch 1.13 under Python 3.11) fails on its own default --redirects/--tee values
("'NoneType' object has no attribute 'get'"): they are given explicitly.

Environment: GLOVEPOSE_CLI (the tool). Needs Debian's python3-torch.
"""
import json
import os
import tempfile
from pathlib import Path
from runner import conclude, run_command

ROOT = Path(__file__).resolve().parents[2]
CLI = os.environ["GLOVEPOSE_CLI"]
EPOCHS, BATCH = "20", "256"


def main():
    with tempfile.TemporaryDirectory() as work:
        run_command([CLI, "simulate", "--world", "clean", "--seed", "5", "--subjects", "3", "--sessions", "2", "--minutes", "0.5", "--gloves", "1",
             "--calibration-seconds", "10", "--out", "corpus.safetensors"], work)
        out = run_command(["torchrun", "--nproc_per_node=2", "--redirects", "1", "--tee", "1", "--log_dir", os.path.join(work, "logs"),
                   str(ROOT / "tools" / "python" / "train_torch.py"), "--data", "corpus.safetensors", "--model", "unet:8",
                   "--exclude-subjects", "2", "--epochs", EPOCHS, "--batch", BATCH, "--seed", "3", "--out", "torch.safetensors"], work)
        print(out.strip().splitlines()[-1])
        run_command([CLI, "train", "--data", "corpus.safetensors", "--model", "unet:8", "--exclude-subjects", "2", "--epochs", EPOCHS,
             "--batch", BATCH, "--seed", "3", "--quiet", "--out", "cpp.safetensors"], work)
        errors = {}
        for name in ("torch", "cpp"):
            report = json.loads(run_command([CLI, "eval", "--model", f"{name}.safetensors", "--data", "corpus.safetensors", "--subjects", "2",
                                     "--json"], work))
            errors[name] = report["mean_deg"]
        info = run_command([CLI, "info", "--model", "torch.safetensors"], work)
    print(f"held-out mean error: PyTorch DDP (2 processes) {errors['torch']:.3f} deg, C++ trainer {errors['cpp']:.3f} deg")
    failures = []
    if "architecture: unet" not in info or "width: 8" not in info:
        failures.append(f"glovepose info does not read the PyTorch model as a U-Net w = 8: {info}")
    if not abs(errors["torch"] - errors["cpp"]) <= 0.1 * errors["cpp"]:
        failures.append(f"the PyTorch model's {errors['torch']:.3f} deg is not within 10% of the C++ trainer's {errors['cpp']:.3f}")
    conclude(failures)


if __name__ == "__main__":
    main()
