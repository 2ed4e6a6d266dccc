"""The machine code of the run-time kernels: one fixed x86-64 target, so every machine computes the same bits.

numba compiles for the host CPU by default: on a CPU with FMA the plant kernels'
``fastmath={"reassoc", "contract"}`` fuse multiply-adds, and the width of the vector registers
(SSE2, AVX2, AVX-512) decides the order of their reductions. The rattling of a friction joint
amplifies such last-bit differences into visible ones (docs/determinism.md), and a log written
on one machine no longer replays bit for bit on another. frictionrt therefore compiles for
numba's ``generic`` target: the x86-64 baseline (SSE2, no FMA), which every x86-64 CPU runs and
on which the same LLVM emits the same instructions whatever the host. The cost is measured in
docs/determinism.md.

The environment variable ``FRICTIONRT_CPU`` chooses: ``generic`` (the default) or ``host``
(numba's own choice: faster on some machines, bit-exact only on the same CPU model). A user's
own ``NUMBA_CPU_NAME`` / ``NUMBA_CPU_FEATURES`` win over both, as ``NUMBA_CACHE_DIR`` does over
rt.common.jit_cache. numba reads ``NUMBA_CPU_NAME`` when its configuration loads and fixes the target
when the first kernel is decorated, so ``configure`` runs in ``rt/common/__init__`` before numba is
imported there; ``check`` tells, at design time, whether that worked (another package may have
compiled a kernel first).
"""
from __future__ import annotations

import os
import warnings

TARGET_ENV = "FRICTIONRT_CPU"
TARGETS = ("generic", "host")


def requested() -> str:
    """The target asked for: ``FRICTIONRT_CPU`` if valid, else ``generic`` (with a warning)."""
    target = os.environ.get(TARGET_ENV, "generic")
    if target not in TARGETS:
        warnings.warn(f"{TARGET_ENV}={target!r}: expected one of {', '.join(TARGETS)}; using generic",
                      stacklevel=2)
        return "generic"
    return target


def configure() -> None:
    """Ask numba for the requested target (module docstring); call before numba compiles anything."""
    if "NUMBA_CPU_NAME" in os.environ or "NUMBA_CPU_FEATURES" in os.environ or requested() == "host":
        return
    os.environ["NUMBA_CPU_NAME"] = "generic"   # numba derives CPU_FEATURES = "" from it
    import sys
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba already imported: set what its loaded configuration holds too
        config.CPU_NAME, config.CPU_FEATURES = "generic", ""


def compiled_target() -> dict[str, str]:
    """What numba compiles the kernels for: {"triple", "cpu", "features"} (features "" = the
    target's baseline), read from its code generator."""
    from numba.core.registry import cpu_target
    triple, cpu, features = cpu_target.target_context.codegen().magic_tuple()
    return {"triple": triple, "cpu": cpu, "features": features}


def check() -> None:
    """RuntimeError if the kernels are not compiled for the requested target (numba fixed its
    target before ``configure`` ran), naming the remedy."""
    if "NUMBA_CPU_NAME" in os.environ and os.environ["NUMBA_CPU_NAME"] != "generic":
        return  # the user's own choice
    if requested() == "host" and "NUMBA_CPU_NAME" not in os.environ:
        return
    t = compiled_target()
    if t["features"] != "":
        raise RuntimeError("numba's code generator was set up with this CPU's features, not for the generic "
                           "x86-64 target frictionrt asks for (a kernel was compiled before frictionrt was imported); "
                           "set NUMBA_CPU_NAME=generic in the environment, or FRICTIONRT_CPU=host to accept it")
