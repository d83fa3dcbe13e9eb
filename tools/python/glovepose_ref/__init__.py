"""glovepose_ref: the PyTorch reference of glovepose's networks (U-Net, FCN, linear) and their files.

Modules:
    safetensors_io  reader/writer of the safetensors-compatible container (weights_format.md)
    model           the U-Net (paper Table 6) with the tensor names of weights_format.md
    export          model (UNet, FCN or torch.nn.Linear(inputs, 25)) <-> model file with glovepose
                    metadata; import_model_with_info also returns the parsed metadata (ModelInfo)
    fcn             the paper's fully connected baseline (appendix A) and its random initialisation
    fast_convolution  use_fast_transposed_convolution(): ConvTranspose2d as the equivalent
                    convolution (Debian's PyTorch 1.13 runs the former 10-40x slower on the CPU)
    paper_networks  the paper's LSTM, ResNet and CGAN discriminator (Sec. 5.4, appendix A), for
                    re-running its Tables 4 and 5 (glovepose does not run them)

Needs PyTorch from Debian (`python3-torch`): run with /usr/bin/python3.
"""

from .model import PRESETS, UNet, count_parameters, randomize
from .fcn import FCN, randomize_fcn
from .safetensors_io import load, save
from .export import ModelFileError, ModelInfo, export_model, import_model, import_model_with_info
from .fast_convolution import use_fast_transposed_convolution

__all__ = [
    "PRESETS",
    "UNet",
    "count_parameters",
    "randomize",
    "FCN",
    "randomize_fcn",
    "load",
    "save",
    "ModelFileError",
    "ModelInfo",
    "export_model",
    "import_model",
    "import_model_with_info",
    "use_fast_transposed_convolution",
]
