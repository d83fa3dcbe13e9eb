"""The README's Python install block, run as written: a virtual environment that sees Debian's
packages, `cmake --install` of this build into it, `pip install` of ./python from no registry, and
the import; only `.venv` (a scratch folder here), `build` (this build tree) and `python3` (the
Debian Python running this test, which a PATH such as pyenv's may hide) are substituted. The
installed package must be the one imported (from the venv's site-packages), must load the installed
libglovepose_c (found in the venv's lib/, with GLOVEPOSE_LIBRARY unset and no build tree beside it)
and, for glovepose.evaluate, the installed libglovepose_eval beside it, and must print the version
and the shipped model's 44 cells.

Environment: GLOVEPOSE_BUILD_DIR (the build tree).
"""
import os
import re
import shlex
import subprocess
import sys
import tempfile

from readme_blocks import sh_commands

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
BUILD = os.environ["GLOVEPOSE_BUILD_DIR"]


def package_version():
    """python/pyproject.toml's version, which must be the C library's (glovepose_version())."""
    text = open(os.path.join(ROOT, "python", "pyproject.toml"), encoding="utf-8").read()
    return re.search(r'^version = "([^"]+)"', text, re.M).group(1)


def main():
    lines = sh_commands("## Python")
    if len(lines) != 4:
        sys.exit(f"FAIL: expected the README's 4 install commands, found {lines}")
    env = {k: v for k, v in os.environ.items() if k not in ("GLOVEPOSE_LIBRARY", "GLOVEPOSE_EVAL_LIBRARY", "PYTHONPATH", "VIRTUAL_ENV")}
    with tempfile.TemporaryDirectory() as work:
        venv = os.path.join(work, "venv")
        output = ""
        for line in lines:
            words = [venv + w[len(".venv"):] if w.startswith(".venv") else w for w in shlex.split(line)]
            if words[0] == "python3":
                words[0] = sys.executable
            if words[:2] == ["cmake", "--install"]:
                words[2] = BUILD
            print("$", shlex.join(words), flush=True)
            result = subprocess.run(words, cwd=ROOT, env=env, capture_output=True, text=True)
            if result.returncode != 0:
                sys.exit(f"FAIL: {shlex.join(words)} exited {result.returncode}\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}")
            output = result.stdout
        print(output.strip())
        if output.split() != [package_version(), "44"]:
            sys.exit(f"FAIL: the import printed {output!r}, expected the version of python/pyproject.toml "
                     f"({package_version()}) and 44 cells")
        where = subprocess.run([os.path.join(venv, "bin", "python"), "-c",
                                "import glovepose; print(glovepose.__file__); print(glovepose._lib._name); print(glovepose._eval_library()._name)"],
                               cwd="/", env=env, capture_output=True, text=True)
        if where.returncode != 0 or len(where.stdout.split()) != 3:
            sys.exit(f"FAIL: the package's libraries from the virtual environment: {where.stdout}{where.stderr}")
        package, library, evaluation = where.stdout.split()
        if not all(p.startswith(venv) for p in (package, library, evaluation)):
            sys.exit(f"FAIL: imported {package} with {library} and {evaluation}; expected all three from the virtual environment {venv}")
        print(f"package {package}, library {library}, evaluation library {evaluation}")
    print("PASS")


if __name__ == "__main__":
    main()
