"""A file written whole or not at all, as the C++ library writes its files (io/atomic_file.hpp):
the bytes go to a temporary file beside the target, are flushed to the disk and renamed over it;
a failure or a kill leaves the target as it was. Needs nothing beyond the standard library."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Union

PathLike = Union[str, "os.PathLike[str]"]


def write_whole(path: PathLike, data: Union[bytes, str]) -> None:
    """Writes `data` (str as UTF-8) to `path`, whole or not at all."""
    target = Path(path)
    partial = target.with_name(f"{target.name}.partial-{os.getpid()}")
    raw = data.encode("utf-8") if isinstance(data, str) else data
    try:
        with open(partial, "wb") as f:
            f.write(raw)
            f.flush()
            os.fsync(f.fileno())
        os.replace(partial, target)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    if hasattr(os, "O_DIRECTORY"):  # the rename is durable once the directory's entry is on the disk
        directory = os.open(target.parent if str(target.parent) else ".", os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(directory)
        finally:
            os.close(directory)
