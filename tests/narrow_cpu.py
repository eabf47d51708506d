"""Print the environment of the narrowed numeric run (``make test-narrow``), as shell
assignments.

The numeric tests run a second time as if on another CPU, so that an expectation tied to the
developer's machine fails there before it fails on a user's:

- ``NPY_DISABLE_CPU_FEATURES``: every SIMD target numpy dispatches to on this CPU (numpy 2.x
  groups such as ``X86_V3 X86_V4 AVX512_ICL``, numpy 1.x names such as ``AVX2 AVX512_SKX``),
  so that numpy runs its baseline kernels (``sin``, ``arctan2``, ``exp``, sorting, ...). Only
  targets this CPU supports are listed: numpy refuses to disable one it does not have.
- ``OPENBLAS_CORETYPE=Haswell`` on a CPU with AVX-512: OpenBLAS's AVX2 kernels instead of its
  AVX-512 ones (other summation order in matrix products and solves).
- ``HDRFRINGE_NATIVE=0``: the numpy paths instead of the native C kernels.

Usage: ``env $(python tests/narrow_cpu.py) pytest ...``.
"""

from __future__ import annotations

import importlib


def narrowed_environment() -> dict[str, str]:
    """The variables of the narrowed run, by name."""
    try:
        umath = importlib.import_module("numpy._core._multiarray_umath")
    except ImportError:  # numpy 1.x
        umath = importlib.import_module("numpy.core._multiarray_umath")
    features: dict[str, bool] = umath.__cpu_features__
    dispatch = [name for name in umath.__cpu_dispatch__ if features.get(name)]
    env = {"HDRFRINGE_NATIVE": "0"}
    if dispatch:
        env["NPY_DISABLE_CPU_FEATURES"] = ",".join(dispatch)
    if features.get("AVX512F") and features.get("AVX2"):
        env["OPENBLAS_CORETYPE"] = "Haswell"
    return env


if __name__ == "__main__":
    print(" ".join(f"{k}={v}" for k, v in narrowed_environment().items()))
