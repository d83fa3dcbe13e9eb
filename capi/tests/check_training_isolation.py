#!/usr/bin/env python3
"""The engines' library holds loading and the per-frame calls only: no training or simulator code.

Two reads, both must be clean:
- the includes: SOURCE's #include lines followed through INCLUDE_DIR's glovepose headers (every
  #include counted, whatever #if surrounds it) reach no header under glovepose/train/ or glovepose/sim/;
- the symbols: `nm -C LIBRARY` (the whole symbol table, local symbols too: inline functions and
  template instances kept out of line show there) names nothing of glovepose::train or glovepose::sim.
A table with no glovepose:: symbol at all (a stripped library) is refused rather than passed.
Each offending header (with the chain of includes reaching it) and symbol is listed.

Usage: check_training_isolation.py NM LIBRARY SOURCE INCLUDE_DIR
"""
import os
import re
import subprocess
import sys

FORBIDDEN_HEADERS = ("glovepose/train/", "glovepose/sim/")
FORBIDDEN_SYMBOLS = re.compile(r"\bglovepose::(train|sim)::")
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)


def forbidden_includes(source, include_dir):
    """(header, chain) for each forbidden header reached from source; chain: the files leading to it.
    Followed: headers under include_dir and beside source (capi/'s own); others (the standard
    library, Eigen, xsimd, nlohmann-json) are not ours."""
    include_dir = os.path.realpath(include_dir)
    own_dir = os.path.dirname(os.path.realpath(source))
    found = set()
    seen = set()
    stack = [(os.path.realpath(source), ())]
    while stack:
        path, chain = stack.pop()
        if path in seen:
            continue
        seen.add(path)
        chain = chain + (os.path.basename(path),)
        with open(path, encoding="utf-8") as f:
            includes = INCLUDE.findall(f.read())
        for kind, name in includes:
            places = ([os.path.join(os.path.dirname(path), name)] if kind == '"' else []) + [os.path.join(include_dir, name)]
            target = next((os.path.realpath(p) for p in places if os.path.isfile(p)), None)
            if target is None:
                continue
            if target.startswith(include_dir + os.sep):
                inside = os.path.relpath(target, include_dir)
                if inside.startswith(FORBIDDEN_HEADERS):
                    found.add((inside, chain))
                    continue
            elif os.path.dirname(target) != own_dir:
                continue
            stack.append((target, chain))
    return sorted(found)


def main():
    if len(sys.argv) != 5:
        sys.exit("usage: check_training_isolation.py NM LIBRARY SOURCE INCLUDE_DIR")
    nm, library, source, include_dir = sys.argv[1:]
    headers = forbidden_includes(source, include_dir)
    for header, chain in headers:
        print(f"{os.path.basename(source)} includes {header} (through {' -> '.join(chain)})")

    done = subprocess.run([nm, "-C", library], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"'{nm} -C {library}' failed ({done.returncode}): {done.stderr.strip()}")
    names = [line.split(" ", 2)[-1] for line in done.stdout.splitlines() if line.strip()]
    ours = [n for n in names if "glovepose::" in n]
    if not ours:
        sys.exit(f"{library}: no glovepose:: symbol in its table ({len(names)} symbols; stripped?): nothing to check, "
                 "expected the symbol table of an unstripped build")
    symbols = sorted({n for n in ours if FORBIDDEN_SYMBOLS.search(n)})
    for name in symbols[:30]:
        print(f"{os.path.basename(library)} holds {name[:200]}")
    if len(symbols) > 30:
        print(f"... and {len(symbols) - 30} more")
    print(f"{library}: {len(headers)} train/ or sim/ headers included, {len(symbols)} of its {len(ours)} glovepose:: symbols "
          "are glovepose::train or glovepose::sim (expected 0 and 0)")
    sys.exit(1 if headers or symbols else 0)


if __name__ == "__main__":
    main()
