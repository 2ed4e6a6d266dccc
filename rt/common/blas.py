"""The design's linear algebra: one OpenBLAS kernel family and one thread, so every x86-64 machine builds the same bits.

numpy and scipy each load OpenBLAS, which picks its kernels per CPU (Haswell for AVX2, SkylakeX
for AVX-512, ...) and splits a product over as many threads as the machine has cores. Both
change the last bits of the design (the plant's eigenproblems and static preload, the observer's
Riccati equation, every ``expm``) and of the reproduction's harmonic fits; the stick-slip of the
joint amplifies them into peak differences of up to 0.8 dB and moved a claim's verdict between
two machines (docs/experiments.md, "Two code generations"). So, before numpy is loaded,
frictionrt asks OpenBLAS for

- its ``Haswell`` kernels (AVX2 and FMA: every x86-64 CPU of the last decade; a CPU without them,
  or another architecture, keeps OpenBLAS's own choice), and
- one thread (the design's matrices are small; the diagnosis ran on one thread already, for speed).

With both, the design is bit-identical under numpy's SIMD levels and glibc's libm variants
(measured, docs/determinism.md). A user's own ``OPENBLAS_CORETYPE`` / ``OPENBLAS_NUM_THREADS``
win, as ``NUMBA_CPU_NAME`` does over rt.common.codegen. If numpy was imported before frictionrt,
its OpenBLAS has chosen already: ``check`` (at design time) then holds it at one thread and warns
once when its kernels are not the pinned ones. ``state`` is what a run's log records.
"""
from __future__ import annotations

import os
import platform
import sys
import warnings

KERNELS = "Haswell"           # OPENBLAS_CORETYPE asked for on x86-64 CPUs with AVX2 and FMA
THREADS = "1"                 # OPENBLAS_NUM_THREADS
_asked: dict[str, str] = {}   # what configure put into the environment
_warned = False


def _cpu_runs_kernels() -> bool:
    """True on an x86-64 CPU with AVX2 and FMA (llvmlite's view of the host; it does not load numpy)."""
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    try:
        from llvmlite import binding
        features = binding.get_host_cpu_features()
    except (ImportError, RuntimeError):
        return False
    return bool(features.get("avx2")) and bool(features.get("fma"))


def configure() -> None:
    """Put the pinned kernels and thread count into the environment (module docstring) unless the
    user set them or numpy is loaded already; call before numpy is imported."""
    if "numpy" in sys.modules:
        return
    wanted = {"OPENBLAS_NUM_THREADS": THREADS}
    if _cpu_runs_kernels():
        wanted["OPENBLAS_CORETYPE"] = KERNELS
    for name, value in wanted.items():
        if name not in os.environ:
            os.environ[name] = value
            _asked[name] = value


def state() -> list[dict[str, object]]:
    """The BLAS libraries loaded in this process: [{"library", "version", "kernels", "threads"}]
    (threadpoolctl's view; "kernels" is OpenBLAS's architecture, "" for another BLAS)."""
    from threadpoolctl import threadpool_info
    return sorted(({"library": os.path.basename(d.get("filepath", "")), "version": d.get("version") or "",
                    "kernels": d.get("architecture") or "", "threads": int(d.get("num_threads", 0))}
                   for d in threadpool_info() if d.get("user_api") == "blas"), key=lambda d: d["library"])


def check() -> None:
    """At design time: hold OpenBLAS at one thread if the user did not ask for another count, and
    warn once if its kernels are not the pinned ones although frictionrt asked for them (numpy
    was imported first)."""
    global _warned
    libs = state()
    if "OPENBLAS_NUM_THREADS" not in os.environ or _asked.get("OPENBLAS_NUM_THREADS"):
        if any(lib["threads"] != int(THREADS) for lib in libs):
            from threadpoolctl import threadpool_limits
            threadpool_limits(limits=int(THREADS), user_api="blas")   # for the rest of the process
    pinned = _asked.get("OPENBLAS_CORETYPE") or ("" if "OPENBLAS_CORETYPE" in os.environ or not _cpu_runs_kernels()
                                                 else KERNELS)
    other = sorted({lib["kernels"] for lib in libs if lib["kernels"] and lib["kernels"] != pinned})
    if pinned and other and not _warned:
        _warned = True
        warnings.warn(f"OpenBLAS runs its {', '.join(other)} kernels, not the {pinned} ones frictionrt pins "
                      "(numpy was imported before frictionrt): the design may differ from another machine's in "
                      f"its last bits; `import frictionrt` before numpy, or set OPENBLAS_CORETYPE={pinned} in the "
                      "environment (docs/determinism.md)", stacklevel=3)
