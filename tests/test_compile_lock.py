"""The lock between processes around a cached kernel's compile (rt.common.jit_cache.install_compile_lock):
a process that needs a kernel another one is compiling waits for it, and of two that start together
one compiles and the other loads the machine code from the disk cache."""
import fcntl
import os
import subprocess
import sys
import textwrap
import time

from numba import types

from frictionrt.rt.common.jit_cache import lock_path

KERNEL = textwrap.dedent("""
    import frictionrt.rt.common   # installs the lock (before any kernel compiles)
    import numba

    @numba.njit(cache=True)
    def f(x):
        return x + 1.0
""")

RUN = textwrap.dedent("""
    import lockmod
    import numba
    numba.njit(lambda x: x * 2.0)(1.0)   # numba's first compile (LLVM's set-up), uncached: no lock
    print("ready", flush=True)
    y = lockmod.f(1.0)
    s = lockmod.f.stats
    print(y, sum(s.cache_hits.values()), sum(s.cache_misses.values()), flush=True)
""")


def test_a_process_waits_for_the_lock_and_one_of_two_compiles(tmp_path):
    (tmp_path / "lockmod.py").write_text(KERNEL)
    cache = tmp_path / "cache"
    def f(x):   # the kernel's name as the subprocesses see it
        pass
    f.__module__, f.__qualname__ = "lockmod", "f"
    lock = lock_path(f, (types.float64,), folder=cache)
    lock.parent.mkdir(parents=True)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache),
               PYTHONPATH=os.pathsep.join([str(tmp_path)] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    with open(lock, "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)      # as if another process were compiling f
        procs = [subprocess.Popen([sys.executable, "-c", RUN], env=env, stdout=subprocess.PIPE, text=True)
                 for _ in range(2)]
        for p in procs:
            assert p.stdout.readline().strip() == "ready"
        time.sleep(3.0)                           # f's compile then takes ~0.1 s: nothing but the lock holds them
        assert [p.poll() for p in procs] == [None, None]
    outs = [p.communicate(timeout=120)[0].split() for p in procs]
    assert all(p.returncode == 0 for p in procs)
    assert sorted((float(y), int(hits), int(misses)) for y, hits, misses in outs) == [(2.0, 0, 1), (2.0, 1, 0)]
