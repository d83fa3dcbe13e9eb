"""The one runner of the plain-Python test scripts (no pytest in Debian's base install): a script
registers its checks with @test, and run() calls each, reports PASS/FAIL/SKIP per check, removes
the script's temporary folder and returns the exit code. Scripts that run one scenario collect
their failures and end with conclude(); run_command() runs a program a scenario needs."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import traceback
from pathlib import Path
from typing import Callable, List, Sequence


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


def run_command(args: Sequence[str], cwd: str) -> str:
    """args' stdout; exits the test with its output when it fails."""
    result = subprocess.run(list(args), cwd=cwd, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"FAIL: {' '.join(map(str, args))}\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}")
    return result.stdout


def conclude(failures: List[str]) -> None:
    """Exits with every failure named, or prints PASS."""
    if failures:
        sys.exit("FAIL: " + "; ".join(failures))
    print("PASS")
