"""glovepose_ref: the PyTorch reference of glovepose's U-Net and its weight-file container.

Modules:
    safetensors_io  reader/writer of the safetensors-compatible container (weights_format.md)
    model           the U-Net (paper Table 6) with the tensor names of weights_format.md
    export          model <-> file with glovepose metadata; random initialisation for tests
    fcn             the paper's fully connected baseline (appendix A) and its random initialisation

Needs PyTorch from Debian (`python3-torch`): run with /usr/bin/python3.
"""

from .model import PRESETS, UNet, count_parameters, randomize
from .fcn import FCN, randomize_fcn
from .safetensors_io import load, save
from .export import export_model, import_model

__all__ = [
    "PRESETS",
    "UNet",
    "count_parameters",
    "randomize",
    "FCN",
    "randomize_fcn",
    "load",
    "save",
    "export_model",
    "import_model",
]
