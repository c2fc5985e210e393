"""What the CPU computes with: the instruction sets that decide the speed of training and inference, and the int8
kernels ONNX Runtime picks (docs/results/latency.md, "int8 on every CPU"). Read from Linux's /proc/cpuinfo (its
`flags` on x86, `Features` on ARM); under user-mode emulation that is the host's, not the emulated CPU's. Plain
Python, no torch: benchmarks/int8_kernels.py uses it on a CPU that has only ONNX Runtime."""

from __future__ import annotations

import os
import platform
from pathlib import Path

# Linux's names of the sets that matter here, and how they are said
NAMES = {"avx2": "AVX2", "avx512f": "AVX-512", "avx512_vnni": "VNNI", "avx_vnni": "AVX-VNNI", "avx512_bf16": "BF16",
         "amx_bf16": "AMX-BF16", "amx_int8": "AMX-INT8", "asimd": "NEON", "asimddp": "dot product", "i8mm": "I8MM",
         "bf16": "BF16", "sve": "SVE"}


def _field(cpuinfo: str | None, *keys: str) -> str | None:
    """The first value of one of `keys` in /proc/cpuinfo (or the text `cpuinfo`), None where there is none."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text()
        except OSError:
            return None
    for line in cpuinfo.splitlines():
        key, _, value = line.partition(":")
        if key.strip() in keys:
            return value.strip()
    return None


def flags(cpuinfo: str | None = None) -> set[str] | None:
    """The CPU's feature flags (of its first processor), None where /proc/cpuinfo cannot be read."""
    value = _field(cpuinfo, "flags", "Features")
    return None if value is None else set(value.split())


def model_name(cpuinfo: str | None = None) -> str:
    """The CPU's name ("AMD EPYC", "Intel(R) Xeon(R) ..."), the architecture where Linux names none."""
    return _field(cpuinfo, "model name", "Model") or platform.machine() or "unknown CPU"


def instruction_sets(cpuinfo: str | None = None) -> str:
    """The instruction sets of NAMES this CPU has, as a result names them: "x86_64: AVX2, AVX-512, VNNI, BF16",
    "x86_64: AVX2 (no AVX-512)", "aarch64: NEON, dot product"."""
    have = flags(cpuinfo)
    arch = platform.machine() or "unknown"
    if have is None:
        return f"{arch}: instruction sets unknown"
    said = ", ".join(name for flag, name in NAMES.items() if flag in have)
    if "avx2" in have and "avx512f" not in have:
        said += " (no AVX-512)"
    return f"{arch}: {said or 'none of ' + ', '.join(dict.fromkeys(NAMES.values()))}"


def bf16_instructions(cpuinfo: str | None = None, environ=os.environ) -> bool | None:
    """Whether torch computes in bfloat16 on this CPU itself: the CPU has x86's avx512_bf16 or amx_bf16, and oneDNN
    is not kept below them (ONEDNN_MAX_CPU_ISA: AVX2, AVX512_CORE or AVX512_CORE_VNNI, say); None where the CPU's
    flags cannot be read. `train.precision: bf16` is faster there, emulated and slower elsewhere. x86 only: an ARM
    CPU's bf16 flag is named by `instruction_sets` but not taken here (bfloat16 training on ARM is not measured)."""
    have = flags(cpuinfo)
    if have is None:
        return None
    limit = environ.get("ONEDNN_MAX_CPU_ISA", "ALL").upper()
    return bool({"avx512_bf16", "amx_bf16"} & have) and (limit in ("ALL", "DEFAULT", "")
                                                           or any(k in limit for k in ("BF16", "FP16", "AMX", "AVX10")))
