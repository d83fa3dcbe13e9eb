#!/usr/bin/env python3
"""No code outside an instruction-set variant reaches an AVX instruction (x86-64 ELF or PE).

The compiled library builds the networks once per instruction set, each unit with its own flags
(src/model/network_variant.cpp). A function the linker keeps once for the whole library (an inline
function, a template instance) may come from an AVX unit; if baseline code called that copy, an
SSE2-only CPU would stop on it. The variants' kernels and networks are instances of a type of each
unit's own (`ThisVariant`), and the factories are named after their set: those are the variants' code.
This reads the library's disassembly (objdump) and fails when a function holding an AVX instruction
(a VEX or EVEX encoded one, or a ymm, zmm or mask register) is called or jumped to by a function that
holds none and is not the variants' code.

Usage: check_isa_isolation.py OBJDUMP LIBRARY
"""
import re
import subprocess
import sys


def is_variant(name):  # a mangled name
    return "ThisVariant" in name or re.search(r"make_network_avx(2|512)", name) is not None


def demangle(name):
    done = subprocess.run(["c++filt", name], capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 and done.stdout.strip() else name


def uses_avx(instruction):
    mnemonic = instruction.split()[0] if instruction.split() else ""
    return (mnemonic.startswith("v") or "%ymm" in instruction or "%zmm" in instruction or re.search(r"%k[0-7]\b", instruction)
            is not None)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: check_isa_isolation.py OBJDUMP LIBRARY")
    objdump, library = sys.argv[1:]
    # Mangled names throughout: LLVM's objdump demangles function headers but not call targets.
    text = subprocess.run([objdump, "-d", "--no-show-raw-insn", library], check=True, capture_output=True, text=True).stdout
    # Functions by address: local clones (".isra.0", ".constprop.0") of different units share names.
    names = {}  # address -> mangled name
    avx = set()  # addresses of functions holding an AVX instruction
    calls = []  # (caller address, callee address, or the name called through the PLT)
    function = None
    for line in text.splitlines():
        header = re.match(r"^([0-9a-f]+) <(.*)>:$", line)
        if header:
            function = int(header.group(1), 16)
            names[function] = header.group(2)
            continue
        # "address:<tab>mnemonic operands" (GNU) or "address:<tab>mnemonic<tab>operands" (LLVM)
        fields = line.split("\t")
        if function is None or len(fields) < 2 or not fields[0].strip().endswith(":"):
            continue
        instruction = " ".join(field.strip() for field in fields[1:])
        if uses_avx(instruction):
            avx.add(function)
        target = re.match(r"(call|jmp)\w*\s+(0x)?([0-9a-f]+) <([^>+]*?)(@plt)?(\+0x[0-9a-f]+)?>", instruction)
        if target and not target.group(6):  # a function's start, not a place inside one
            calls.append((function, target.group(4) if target.group(5) else int(target.group(3), 16)))
    by_name = {}
    for address, name in names.items():
        by_name.setdefault(name, []).append(address)
    edges = set()
    for caller, callee in calls:  # a call through the PLT binds to the one copy of the name kept
        for address in (by_name.get(callee, []) if isinstance(callee, str) else [callee]):
            if address != caller and address in names:
                edges.add((caller, address))
    if not any(is_variant(n) for n in names.values()):
        sys.exit(f"{library}: no variant code found (expected the factories make_network_avx2 and the ThisVariant instances)")
    if not any(is_variant(names[a]) for a in avx):
        sys.exit(f"{library}: the variants hold no AVX instruction (expected the AVX2 and AVX-512 kernels)")
    if not edges:
        sys.exit(f"{library}: no call read from the disassembly (an objdump whose format this script does not know?)")
    leaks = sorted({(names[caller], names[callee]) for caller, callee in edges
                    if callee in avx and caller not in avx and not is_variant(names[caller])})
    for caller, callee in leaks[:20]:
        print(f"baseline code calls AVX code: {demangle(caller)[:160]} -> {demangle(callee)[:160]}")
    untagged = sorted(a for a in avx if not is_variant(names[a]))
    print(f"{library}: {len(avx)} functions hold AVX instructions, {len(untagged)} of them outside the variants' own types "
          f"(reached only from AVX code), {len(leaks)} calls into them from baseline code")
    sys.exit(1 if leaks else 0)


if __name__ == "__main__":
    main()
