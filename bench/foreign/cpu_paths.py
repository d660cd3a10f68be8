"""The same bench record on every x86-64 machine with AVX2 and FMA.

OpenBLAS (behind SciPy's LU solves in the integrator) picks its kernels by
CPU (Cooperlake on an AVX-512 EPYC, Haswell or Zen elsewhere), and NumPy its
AVX-512 loops where the CPU has them. Each rounds differently: one seed made a
record on a machine with AVX-512 that differed from the record made on one
without it by up to 1e-5 of a signal's swing, a thousandth of the noise, and
that was enough to turn a fit from one basin to another (docs/diagnosis-history.md,
"One start per valley"; there the OpenBLAS kernel alone made the difference).
Importing this module before NumPy pins both to what every AVX2 machine has:
OpenBLAS on its Haswell kernels, NumPy's AVX-512 loops off. A machine without AVX2 and FMA keeps its
own paths (its records can then differ in the last digits), and so does a run
with RECTIFY_BENCH_NATIVE_CPU=1 set.

Import it first: it raises where NumPy is already loaded, since the setting
would then come too late to take effect.
"""
import os
import sys
import warnings

# NumPy 1.24's dispatched AVX-512 targets (numpy.core._multiarray_umath.__cpu_dispatch__)
NUMPY_AVX512 = ("AVX512F", "AVX512CD", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL", "AVX512_ICL",
                "AVX512_KNL", "AVX512_KNM", "AVX512_SPR")


def _cpu_flags():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def pin():
    """Sets the two libraries' CPU paths; returns what it set ({} if nothing)."""
    if "numpy" in sys.modules:
        raise RuntimeError("bench/foreign/cpu_paths.py must be imported before NumPy")
    if os.environ.get("RECTIFY_BENCH_NATIVE_CPU"):
        return {}
    flags = _cpu_flags()
    if not {"avx2", "fma"} <= flags:
        return {}
    setting = {"OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": " ".join(NUMPY_AVX512)}
    os.environ.update(setting)
    return setting


PINNED = pin()

if PINNED:
    # NumPy warns about the names in the list that this machine or this build
    # does not have (nothing to switch off there); that is expected here
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=RuntimeWarning, message=".*NPY_DISABLE_CPU_FEATURES.*")
        import numpy  # noqa: E402,F401

    try:
        from numpy.core._multiarray_umath import __cpu_features__  # noqa: E402
    except ImportError:  # NumPy 2 moved it; Debian 12's is 1.24
        from numpy._core._multiarray_umath import __cpu_features__  # noqa: E402
    if any(__cpu_features__.get(k) for k in NUMPY_AVX512):
        raise RuntimeError("bench/foreign/cpu_paths.py: NumPy's AVX-512 loops are still on")
