"""The one runner of the plain-Python test scripts (no pytest in Debian's base install): a script
registers its checks with @test, and run() calls each, reports PASS/FAIL/SKIP per check, removes
the script's temporary folder and returns the exit code."""

from __future__ import annotations

import shutil
import tempfile
import traceback
from pathlib import Path
from typing import Callable, List


def expect_error(fn: Callable[[], object], exc: type, fragment: str) -> None:
    """fn raises exc, and its message contains fragment."""
    try:
        fn()
    except exc as e:
        assert fragment in str(e), f"error message {str(e)!r} does not mention {fragment!r}"
        return
    raise AssertionError(f"expected {exc.__name__} mentioning {fragment!r}")


class Skip(Exception):
    """A check that cannot run here (the message says why)."""


class Suite:
    def __init__(self, prefix: str) -> None:
        self.tmp = Path(tempfile.mkdtemp(prefix=prefix))
        self.tests: List[Callable[[], None]] = []

    def test(self, fn: Callable[[], None]) -> Callable[[], None]:
        self.tests.append(fn)
        return fn

    def run(self) -> int:
        passed = failed = skipped = 0
        try:
            for fn in self.tests:
                try:
                    fn()
                    passed += 1
                    print(f"PASS {fn.__name__}")
                except Skip as e:
                    skipped += 1
                    print(f"SKIP {fn.__name__}: {e}")
                except Exception:  # noqa: BLE001 - report every failure and keep going
                    failed += 1
                    print(f"FAIL {fn.__name__}")
                    traceback.print_exc()
        finally:
            shutil.rmtree(self.tmp, ignore_errors=True)
        print(f"{passed} passed, {failed} failed, {skipped} skipped")
        return 0 if failed == 0 else 1
