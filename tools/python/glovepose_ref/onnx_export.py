"""Export of the reference U-Net to ONNX, for the peer benchmark (bench/peers).

Uses torch.onnx.export (TorchScript-based in PyTorch 1.13; it needs no `onnx` Python module).
The graph has one input `input` [batch, 2 + E, 5, 5] (E = model.extra_inputs, the glove's extra
input planes; 0 for the paper's network) and one output `output` [batch, 1, 5, 5], float32, the
batch axis dynamic. BatchNorm is exported in eval mode (inference BatchNormalization nodes,
which ONNX Runtime fuses into the convolutions with graph optimisations on).
"""

from __future__ import annotations

from pathlib import Path
from typing import Union

import torch

from .model import UNet

#: Opset 17 is the newest PyTorch 1.13 writes; ONNX Runtime 1.30 reads it.
OPSET = 17


def export_onnx(model: UNet, path: Union[str, Path], opset: int = OPSET) -> None:
    """Writes `model` (evaluated in eval mode, float32) to `path` as ONNX with a dynamic batch axis."""
    was_training = model.training
    model = model.eval()
    x = torch.zeros(1, 2 + model.extra_inputs, 5, 5, dtype=torch.float32)
    with torch.no_grad():
        torch.onnx.export(
            model,
            (x,),
            str(path),
            input_names=["input"],
            output_names=["output"],
            dynamic_axes={"input": {0: "batch"}, "output": {0: "batch"}},
            opset_version=opset,
            do_constant_folding=True,
            training=torch.onnx.TrainingMode.EVAL,
        )
    model.train(was_training)
