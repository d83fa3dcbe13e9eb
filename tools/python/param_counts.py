#!/usr/bin/env python3
"""Prints the parameter counts of the U-Net presets. Usage: /usr/bin/python3 tools/python/param_counts.py"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from glovepose_ref.model import _main  # noqa: E402

if __name__ == "__main__":
    _main()
