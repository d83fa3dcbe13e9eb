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


def is_variant(name):
    return "ThisVariant" in name or re.search(r"make_network_(avx2|avx512)\b", name) is not None


def uses_avx(instruction):
    mnemonic = instruction.split()[0] if instruction.split() else ""
    return (mnemonic.startswith("v") or "%ymm" in instruction or "%zmm" in instruction or re.search(r"%k[0-7]\b", instruction)
            is not None)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: check_isa_isolation.py OBJDUMP LIBRARY")
    objdump, library = sys.argv[1:]
    text = subprocess.run([objdump, "-d", "--no-show-raw-insn", "-C", library], check=True, capture_output=True, text=True).stdout
    avx = set()
    calls = []  # (caller, callee)
    function = None
    for line in text.splitlines():
        header = re.match(r"^[0-9a-f]+ <(.*)>:$", line)
        if header:
            function = header.group(1)
            continue
        fields = line.split("\t")
        if function is None or len(fields) < 2:
            continue
        instruction = fields[1].strip()
        if uses_avx(instruction):
            avx.add(function)
        target = re.match(r"(call|jmp)\w*\s+[0-9a-f]+ <([^>+]*?)(@plt)?(\+0x[0-9a-f]+)?>", instruction)
        if target and target.group(2) != function:
            calls.append((function, target.group(2)))  # a call through the PLT binds to the one kept copy
    functions = {f for pair in calls for f in pair} | avx
    if not any(is_variant(f) for f in functions):
        sys.exit(f"{library}: no variant code found (expected the factories make_network_avx2 and the ThisVariant instances)")
    if not any(is_variant(f) for f in avx):
        sys.exit(f"{library}: the variants hold no AVX instruction (expected the AVX2 and AVX-512 kernels)")
    leaks = sorted({(caller, callee) for caller, callee in calls if callee in avx and caller not in avx and not is_variant(caller)})
    for caller, callee in leaks[:20]:
        print(f"baseline code calls AVX code: {caller[:160]} -> {callee[:160]}")
    untagged = sorted(f for f in avx if not is_variant(f))
    print(f"{library}: {len(avx)} functions hold AVX instructions, {len(untagged)} of them outside the variants' own types "
          f"(reached only from AVX code), {len(leaks)} calls into them from baseline code")
    sys.exit(1 if leaks else 0)


if __name__ == "__main__":
    main()
