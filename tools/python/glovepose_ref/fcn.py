"""The paper's fully connected baseline (FCN, appendix A) in PyTorch.

The paper's FCN is F44-F2048-F2048-F2048-F2048-F1024-F26: six fully connected layers, ReLU after
the first five, none after the last. glovepose predicts 25 DoFs, so the default output is 25:

    fc1 Linear(inputs, h)   ReLU
    fc2 Linear(h, h)        ReLU
    fc3 Linear(h, h)        ReLU
    fc4 Linear(h, h)        ReLU
    fc5 Linear(h, h // 2)   ReLU
    fc6 Linear(h // 2, outputs)        (no output activation)

Input [N, inputs] (the glove's calibrated sensor values), output [N, outputs]. State-dict keys are
`fc1.weight` [h, inputs], `fc1.bias` [h], ..., `fc6.weight` [outputs, h // 2], `fc6.bias` [outputs]
(nn.Linear stores its weight as [out_features, in_features]).
"""

from __future__ import annotations

import torch
from torch import nn

from .model import seeded_uniform

#: The linear layers, in forward order.
FC_NAMES = ("fc1", "fc2", "fc3", "fc4", "fc5", "fc6")


class FCN(nn.Module):
    """Six-layer MLP of hidden width `hidden` (the paper: 44 inputs, 2048 hidden)."""

    def __init__(self, inputs: int = 44, hidden: int = 2048, outputs: int = 25) -> None:
        super().__init__()
        if inputs < 1 or outputs < 1 or hidden < 2:
            raise ValueError(f"FCN: inputs {inputs}, hidden {hidden}, outputs {outputs}; expected inputs, outputs >= 1, hidden >= 2")
        h = hidden
        self.inputs = inputs
        self.hidden = hidden
        self.outputs = outputs
        self.fc1 = nn.Linear(inputs, h)
        self.fc2 = nn.Linear(h, h)
        self.fc3 = nn.Linear(h, h)
        self.fc4 = nn.Linear(h, h)
        self.fc5 = nn.Linear(h, h // 2)
        self.fc6 = nn.Linear(h // 2, outputs)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """[N, inputs] -> [N, outputs]; ReLU after fc1..fc5, fc6 linear."""
        relu = torch.relu
        x = relu(self.fc1(x))
        x = relu(self.fc2(x))
        x = relu(self.fc3(x))
        x = relu(self.fc4(x))
        x = relu(self.fc5(x))
        return self.fc6(x)


def randomize_fcn(model: FCN, seed: int) -> FCN:
    """Fills every weight with deterministic random values (for tests); returns model.

    Weights Xavier-uniform (a = sqrt(6 / (in_features + out_features))), biases U(-0.1, 0.1), drawn
    in float64 from one torch.Generator seeded `seed` and rounded to the parameters' dtype, layers
    visited in forward order (fc1.weight, fc1.bias, fc2.weight, ...), as `model.randomize` does for
    the U-Net. The values depend only on `seed` and the layer sizes.
    """
    uniform_ = seeded_uniform(seed)

    with torch.no_grad():
        for name in FC_NAMES:
            fc = getattr(model, name)
            fan_out, fan_in = fc.weight.shape
            a = (6.0 / (fan_in + fan_out)) ** 0.5
            uniform_(fc.weight, -a, a)
            uniform_(fc.bias, -0.1, 0.1)
    return model
