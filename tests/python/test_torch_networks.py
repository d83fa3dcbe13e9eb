"""tools/experiments/torch_networks.py, which trains the paper's LSTM, ResNet and CGAN for Tables 4/5:
its score of a glovepose model equals `glovepose eval`'s (against the labels and the truth), and each
of the three networks, trained briefly on two people, predicts a third better than that person's
best constant pose would from the training people (their mean angles).

Data: a small simulated corpus of the default world (3 people, 2 sessions of 30 s, 10 s calibration).

Environment: GLOVEPOSE_CLI (the tool). Needs Debian's python3-torch.
"""
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "python"))
from glovepose_ref import safetensors_io  # noqa: E402
from runner import conclude, run_command  # noqa: E402

CLI = os.environ["GLOVEPOSE_CLI"]
SCRIPT = str(ROOT / "tools" / "experiments" / "torch_networks.py")


def mean_pose_error(corpus: str) -> float:
    """Mean absolute error (deg) on person 2's recording of the training people's mean angles."""
    t, _ = safetensors_io.load(corpus)
    keep = (t["kind"].numpy() == 0) & (t["outlier"].numpy() == 0)
    subject, angles = t["subject"].numpy(), t["angles"].numpy().astype(np.float64)
    mean = angles[keep & (subject != 2)].mean(axis=0)
    return float(np.degrees(np.abs(angles[keep & (subject == 2)] - mean).mean()))


def main():
    failures = []
    with tempfile.TemporaryDirectory() as work:
        run_command([CLI, "simulate", "--seed", "5", "--subjects", "3", "--sessions", "2", "--minutes", "0.5", "--gloves", "1",
             "--calibration-seconds", "10", "--out", "corpus.safetensors"], work)
        # The score: a glovepose model through both
        run_command([CLI, "train", "--data", "corpus.safetensors", "--model", "unet:8", "--exclude-subjects", "2", "--epochs", "2",
             "--seed", "3", "--quiet", "--out", "cpp.safetensors"], work)
        cpp = json.loads(run_command([CLI, "eval", "--model", "cpp.safetensors", "--data", "corpus.safetensors", "--subjects", "2", "--json"], work))
        run_command([sys.executable, SCRIPT, "--data", "corpus.safetensors", "--check-model", "cpp.safetensors", "--eval-subjects", "2",
             "--json", "check.json"], work)
        check = json.loads(Path(work, "check.json").read_text())
        print(f"glovepose eval {cpp['mean_deg']:.4f} / {cpp['vs_truth']['mean_deg']:.4f} deg, "
              f"torch_networks.py {check['mean_deg']:.4f} / {check['vs_truth']['mean_deg']:.4f} deg (labels / truth)")
        for key in ("mean_deg",):
            for name, a, b in (("labels", cpp[key], check[key]), ("truth", cpp["vs_truth"][key], check["vs_truth"][key])):
                if not abs(a - b) <= 2e-3:
                    failures.append(f"against the {name}: torch_networks.py scores {b:.4f} deg, glovepose eval {a:.4f}")
        # The paper's other networks learn
        baseline = mean_pose_error(str(Path(work, "corpus.safetensors")))
        for model in ("lstm:32", "resnet:16", "cgan:8"):
            run_command([sys.executable, SCRIPT, "--data", "corpus.safetensors", "--model", model, "--exclude-subjects", "2",
                 "--eval-subjects", "2", "--epochs", "4", "--batch", "64", "--seed", "3", "--json", "net.json"], work)
            error = json.loads(Path(work, "net.json").read_text())["mean_deg"]
            print(f"{model}: {error:.3f} deg on person 2; the training people's mean pose: {baseline:.3f} deg")
            if not error < baseline:
                failures.append(f"{model} scores {error:.3f} deg, not below the mean pose's {baseline:.3f}")
    conclude(failures)


if __name__ == "__main__":
    main()
