"""Build the native kernels (``src/hdrfringe/core/_native/*.c``) next to the package metadata.

Everything else about the package is declared in ``pyproject.toml``. Each C file becomes one
shared library ``hdrfringe/core/_native/<name>.<EXT_SUFFIX>`` that ``hdrfringe.core._native.load`` opens
with :mod:`ctypes` (plain C functions on raw buffers: no Python or numpy C API, so the kernels do
not depend on the interpreter's ABI and release the GIL while they run). An editable install
(``pip install -e .``) builds them in place; ``make native`` rebuilds them after an edit. Without
a C compiler the package still works: every kernel has a numpy fallback
(docs/architecture.md, "Native kernels").
"""

from pathlib import Path

from setuptools import Extension, setup

NATIVE = Path("src") / "hdrfringe" / "core" / "_native"

# -O3 without -march: the wheel runs on any x86-64 (SSE2 baseline) or aarch64; -ffp-contract=off
# keeps a * b + c as two roundings (no fused multiply-add), so the kernels' float64 results are
# bit-identical to the numpy expressions they replace; -fno-math-errno lets sqrt inline.
FLAGS = ["-O3", "-ffp-contract=off", "-fno-math-errno", "-std=c99"]

# optional=True: a machine without a C compiler still installs the package (numpy paths);
# tests/test_native_decode.py fails in a test environment where the library was not built.
setup(
    ext_modules=[
        Extension(
            f"hdrfringe.core._native.{src.stem}", [str(src)], extra_compile_args=FLAGS, optional=True
        )
        for src in sorted(NATIVE.glob("*.c"))
    ]
)
