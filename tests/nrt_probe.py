"""Heap allocations inside a compiled step, counted by numba's runtime (NUMBA_NRT_STATS=1).

``allocations_per_call(code)`` runs ``code`` in a fresh interpreter with the statistics on.
``code`` defines ``call(n)``, which steps a kernel n times inside one compiled function with
preallocated buffers. The harness compiles it (``call(4)``), then counts the allocations and
frees of ``call(10)`` and ``call(N)``: passing arrays in from Python allocates (unboxing) the
same for both, so any allocation inside the step shows as a difference.
"""
import os
import subprocess
import sys
import textwrap
from pathlib import Path

HARNESS = """
from numba.core.runtime import rtsys
call(4)
counts = []
for n in (10, N_STEPS):
    before = rtsys.get_allocation_stats()
    call(n)
    after = rtsys.get_allocation_stats()
    counts += [after.alloc - before.alloc, after.free - before.free]
print(*counts)
"""


def allocations(code: str, n_steps: int = 2000) -> tuple[int, int, int, int]:
    """(allocs, frees) of call(10) and of call(n_steps)."""
    src = textwrap.dedent(code) + HARNESS.replace("N_STEPS", str(int(n_steps)))
    env = dict(os.environ, NUMBA_NRT_STATS="1")
    out = subprocess.run([sys.executable, "-c", src], capture_output=True, text=True, env=env, timeout=600,
                         check=False, cwd=Path(__file__).resolve().parents[1])
    assert out.returncode == 0, out.stderr
    a10, f10, a_n, f_n = map(int, out.stdout.split())
    return a10, f10, a_n, f_n


def assert_no_allocation_per_step(code: str, n_steps: int = 2000) -> None:
    a10, f10, a_n, f_n = allocations(code, n_steps)
    assert (a_n, f_n) == (a10, f10), f"{a_n - a10} allocations in {n_steps - 10} steps"
    assert a10 == f10  # what the argument unboxing allocates is freed
