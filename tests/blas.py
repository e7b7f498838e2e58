"""Which OpenBLAS kernels the recorded fixtures need, and whether this process has them.

The reference runs (``tests/data/*.json``) hold SHA-256 digests of learnt weights and
kernel parameters: they are reproduced bit for bit only with the OpenBLAS kernels they
were recorded with, :data:`RECORDED_KERNELS`. ``conftest.py`` pins those kernels through
``OPENBLAS_CORETYPE`` before numpy loads, where the CPU can run them.
"""

from __future__ import annotations

import os
from pathlib import Path

RECORDED_KERNELS = "Haswell"
"""OpenBLAS's name of the kernels the reference fixtures were recorded with."""
_NEEDS = {"avx2", "fma"}


def cpu_runs_recorded_kernels() -> bool:
    """Whether this CPU has the instructions :data:`RECORDED_KERNELS` use (Linux only)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return False
    for line in text.splitlines():
        if line.startswith("flags"):
            return _NEEDS <= set(line.split(":", 1)[1].split())
    return False


def pin_recorded_kernels() -> None:
    """Ask OpenBLAS for :data:`RECORDED_KERNELS` (unless ``OPENBLAS_CORETYPE`` is set
    already, or the CPU cannot run them). Must run before numpy is imported."""
    if "numpy" not in __import__("sys").modules and cpu_runs_recorded_kernels():
        os.environ.setdefault("OPENBLAS_CORETYPE", RECORDED_KERNELS)


def blas_kernels() -> set[str]:
    """The kernel names of the OpenBLAS libraries loaded in this process (numpy's and
    scipy's), as threadpoolctl reports them."""
    from threadpoolctl import threadpool_info

    return {str(info.get("architecture")) for info in threadpool_info()
            if info.get("internal_api") == "openblas"}


RECORDED_NUMPY = 2
"""The major version of numpy the fixtures were recorded with: numpy 1.26, which the
project allows, sums and multiplies in other orders (other last bits)."""


def reason_bits_differ() -> str | None:
    """Why this process cannot reproduce the recorded digests (``None``: it can)."""
    import numpy as np

    major = int(np.__version__.split(".")[0])
    if major != RECORDED_NUMPY:
        return (f"the reference fixtures were recorded with numpy {RECORDED_NUMPY}; this "
                f"process runs numpy {np.__version__}, whose results differ in the last bits")
    kernels = blas_kernels()
    if kernels <= {RECORDED_KERNELS}:
        return None
    return (f"the reference fixtures were recorded with OpenBLAS's {RECORDED_KERNELS} kernels; "
            f"this process runs {sorted(kernels)} (the CPU lacks AVX2 and FMA, or "
            "OPENBLAS_CORETYPE names other kernels), which round matrix products differently "
            "in the last bit")
