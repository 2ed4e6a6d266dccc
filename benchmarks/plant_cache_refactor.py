"""Can a restart rebuild the contact solver's factor cache from what is cheap to store?

    python -m benchmarks.plant_cache_refactor [--law lyapunov] [--at 1000 2100] [--after 4200]

The factors of each cache slot (plant/newmark.py ``_contact_newton``) are a function of the constant
Delassus matrix W, the slot's pattern of pair states (``pattern``: the active pairs and their order)
and the Jacobian entries at its factorisation (``d_fact``); the Woodbury rows ``Z`` are a function
of the factors and W, computed when first needed (``z_ok``). So a key frame could carry
``pattern``, ``d_fact``, ``key``, ``last_use`` and ``slot`` (about 3,100 values at the default
mesh, against the whole cache's 111,000) and a restart could refactor every kept slot (the
current one last, so that the transitions' LU is current) and mark every Z row stale.

This script checks that on the run itself: from ``Run.final`` at tick K it wipes LU, Jinv, piv
and Z (NaN), clears z_ok, refactors the slots with the same expressions as ``_contact_newton``,
continues the run, and compares every logged signal but the wall-clock ones bit for bit with the
run continued from the untouched state; and, for reference, the run continued with the cache
forgotten (a cold restart).
"""
from __future__ import annotations

import argparse

import numba
import numpy as np

import frictionrt.rt.common  # noqa: F401
from frictionrt.plant import newmark as nm
from frictionrt.rt.common.config import load
from frictionrt.rt.loop import build_loop, run


@numba.njit(cache=False, _nrt=False, fastmath=nm.FASTMATH)
def refactor(W, LU, Jinv, piv, pattern, d_fact, act, s):
    """Slot s's factors from its pattern and d_fact, as ``_contact_newton`` builds them."""
    npair = pattern.shape[1]
    n_act = 0
    for j in range(npair):
        if pattern[s, j] != 0:
            act[n_act] = j
            n_act += 1
    d = d_fact[s]
    ma = 2 * n_act
    for ra in range(ma):
        i = 2 * act[ra // 2] + ra % 2
        for b in range(n_act):
            j = act[b]
            LU[ra, 2 * b] = -(W[i, 2 * j] * d[3 * j] + W[i, 2 * j + 1] * d[3 * j + 1])
            LU[ra, 2 * b + 1] = -W[i, 2 * j + 1] * d[3 * j + 2]
        LU[ra, ra] += 1.0
    nm._lu_factor(LU, piv[s], ma)
    if s < pattern.shape[0] - 1:
        nm._triangular_inverses(LU, Jinv[s], ma)
    return ma


def rebuilt(st, W):
    """A copy of ``st`` whose factor cache is wiped and rebuilt from pattern and d_fact."""
    s2 = st.copy()
    w = s2.plant_work
    w.Jinv[:] = np.nan
    w.LU[:] = np.nan
    w.piv[:] = 0
    w.Z[:] = np.nan
    w.z_ok[:] = 0
    cur = int(w.slot[0])
    kept = [s for s in range(w.pattern.shape[0]) if w.pattern[s, 0] != -1]
    act = np.zeros(w.pattern.shape[1], np.int64)
    for s in [s for s in kept if s != cur] + [s for s in kept if s == cur]:
        refactor(W, w.LU, w.Jinv, w.piv, w.pattern, w.d_fact, act, s)
    return s2, len(kept)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--law", default="lyapunov")
    ap.add_argument("--at", type=int, nargs="+", default=[1000, 2100], help="restart ticks")
    ap.add_argument("--after", type=int, default=4200, help="ticks run after the restart")
    a = ap.parse_args()
    cfg = load()
    loop = build_loop(cfg, a.law, "observer")
    names = [s[0] if isinstance(s, tuple) else s for s in loop.signals]
    keep = [i for i, n in enumerate(names) if not str(n).endswith("_ns")]
    cheap = ("pattern", "d_fact", "key", "last_use", "slot")
    print("| restart tick | kept slots | current slot | values stored (cheap / whole cache) | rebuilt: bit-exact | "
          "cold: largest abs diffs |")
    print("| --- | --- | --- | --- | --- | --- |")
    for k0 in a.at:
        st = run(loop, 205.0, 5.0, k0 / 21000).final
        wk = st.plant_work
        whole = sum(getattr(wk, f).size for f in nm.PlantWork._fields if f in cheap + ("LU", "Jinv", "piv", "Z", "z_ok"))
        small = sum(getattr(wk, f).size for f in cheap)
        ref = run(loop, 205.0, 5.0, a.after / 21000, start=st).log[:, keep]
        s2, n_kept = rebuilt(st, loop.plant.params.W)
        got = run(loop, 205.0, 5.0, a.after / 21000, start=s2).log[:, keep]
        cold = st.copy()
        nm._forget_factors(cold.plant_work.pattern)
        c = run(loop, 205.0, 5.0, a.after / 21000, start=cold).log[:, keep]
        dif = np.nanmax(np.abs(c - ref), axis=0)
        worst = [(names[keep[i]], float(dif[i])) for i in np.argsort(dif)[::-1][:3]]
        print(f"| {k0} | {n_kept} | {int(wk.slot[0])} | {small} / {whole} | "
              f"{np.array_equal(got.view(np.uint64), ref.view(np.uint64))} | "
              + ", ".join(f"{n} {v:.3g}" for n, v in worst) + " |",
              flush=True)


if __name__ == "__main__":
    main()
