"""The numerical machine the tests run on, and the settings of another valid one (used by ``.ci/run``).

The last bits of NumPy's linear algebra and of its vectorised functions depend on the CPU: NumPy's OpenBLAS picks
its kernels at run time (``OPENBLAS_CORETYPE`` overrides it), and NumPy dispatches its loops to the widest SIMD
instructions available (``NPY_DISABLE_CPU_FEATURES`` switches targets off).  A test that sits on the last bit passes
on one machine and fails on another with the same packages (issue 23: ``max |tau| > 0.5`` held on an AVX-512
machine and failed on an AVX2 one).

``python .ci/machine.py`` prints the kernel and the SIMD targets in use.  ``python .ci/machine.py --other`` prints
shell assignments that make the same packages compute as on another common machine (an AVX2 one where this one
has AVX-512, an AVX-512 or an AVX one where this one is AVX2), or nothing where no other setting is known.
"""

from __future__ import annotations

import ctypes
import os
import sys
from pathlib import Path

import numpy as np

try:  # NumPy's dispatch tables (not a public API: without them, only the OpenBLAS kernel is known)
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__
except ImportError:  # pragma: no cover - another NumPy layout
    __cpu_dispatch__, __cpu_features__ = [], {}

_AVX512_KERNELS = ("skylakex", "cooperlake", "sapphirerapids")


def openblas_core() -> str | None:
    """The OpenBLAS kernel NumPy's bundled library runs with (``None`` when it cannot be read)."""
    libs = Path(np.__file__).parent.parent / "numpy.libs"
    for lib in sorted(libs.glob("*openblas*")):
        try:
            dll = ctypes.CDLL(str(lib))
        except OSError:
            continue
        for name in ("scipy_openblas_get_corename64_", "openblas_get_corename64_", "openblas_get_corename"):
            func = getattr(dll, name, None)
            if func is not None:
                func.restype = ctypes.c_char_p
                return func().decode()
    return None


def other_machine(core: str | None) -> dict[str, str]:
    """Environment variables that emulate another common machine with the same packages (may be empty).

    Empty where the machine itself sets ``OPENBLAS_CORETYPE`` or ``OPENBLAS_L2_SIZE`` (some processors need them:
    older OpenBLAS builds compute wrong results or crash there), so that a setting the machine made is never changed.
    """
    if os.environ.get("OPENBLAS_CORETYPE") or os.environ.get("OPENBLAS_L2_SIZE"):
        return {}
    if core is None or not __cpu_features__.get("AVX2"):
        return {}
    if core.lower() in _AVX512_KERNELS:  # an AVX-512 machine: compute as an AVX2 one does
        targets = [t for t in __cpu_dispatch__ if t == "X86_V4" or t.startswith("AVX512")]
        return {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": " ".join(targets)}
    if __cpu_features__.get("AVX512F"):  # AVX-512 hardware running AVX2 kernels: use the AVX-512 ones
        return {"OPENBLAS_CORETYPE": "SkylakeX"}
    return {"OPENBLAS_CORETYPE": "Sandybridge"}  # an AVX2 machine: the AVX kernels of older CPUs


def main(argv: list[str]) -> int:
    core = openblas_core()
    if argv == ["--other"]:
        for key, value in other_machine(core).items():
            print(f"export {key}='{value}'")
        return 0
    if argv:
        print("usage: python .ci/machine.py [--other]", file=sys.stderr)
        return 2
    enabled = [t for t in __cpu_dispatch__ if __cpu_features__.get(t)]
    print(f"OpenBLAS kernel: {core or 'unknown'}; NumPy SIMD targets in use: {' '.join(enabled) or 'baseline only'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
