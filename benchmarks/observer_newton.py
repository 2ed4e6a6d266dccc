"""Iterations per tick of the observer's implicit friction step, before and after a change of its
stopping rule, on the same logs.

    python -m benchmarks.observer_newton LOG.mcap [LOG.mcap ...] [--json OUT.json]

For each log the observer's inputs of every tick are taken from the log (the integrated tip
velocity v_tip_meas and the force cell's F_cell, a non-finite reading replaced by the last
finite one as the supervisor's sanitiser does; logs with an observer_mismatch fault are
refused) and the observer is run open loop over them twice: with the Newton of kernel version 1
(``_implicit_v_v1``: the bracket test before the convergence test) and with the production one
(``frictionrt.observer.step._implicit_v_iter``, which returns its count), each counting its iterations. The run whose kernel
recorded the log must reproduce the log's observer outputs bit for bit (checked and reported:
``reproduces_log``), so the counts are those of the controller that ran.

Prints, per log and variant, the median, 99th percentile and maximum of the iterations per tick,
the ticks that needed more than 8, and the largest |v_next| difference between the two variants.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numba
import numpy as np

from frictionrt.observer.step import NEWTON_MAX, _friction, _implicit_v_iter
from frictionrt.rt.common.kernel_version import logged_version


@numba.njit(cache=True)
def _implicit_v_v1(v_star, beta, F_N, mu, alpha):
    """The Newton of kernel version 1 (bracket test first: a converged step equal to an end of
    the bracket is rejected and the loop bisects). Returns (v, iterations)."""
    lo = min(0.0, v_star)
    hi = max(0.0, v_star)
    v = v_star
    tol = 1e-15 * (abs(v_star) + 1e-12)
    for it in range(NEWTON_MAX):
        f, df = _friction(v, F_N, mu, alpha)
        g = v - beta * f - v_star
        if g > 0.0:
            hi = v
        else:
            lo = v
        v_new = v - g / (1.0 - beta * df)
        if not (lo < v_new < hi):
            v_new = 0.5 * (lo + hi)
        if abs(v_new - v) <= tol:
            return v_new, it + 1
        v = v_new
    return v, NEWTON_MAX


@numba.njit(cache=True)
def _run(x0, y_meas, F_N, p, variant, y, it):
    """The observer (``frictionrt.observer.step._observer_step``'s arithmetic) over the inputs with
    Newton ``variant`` (0 version 1, 1 production); y (n, 4) outputs, it (n,) iterations.
    """
    x = x0.copy()
    xn = np.empty_like(x)
    n = x.shape[0]
    for k in range(y_meas.shape[0]):
        e = y_meas[k]
        for i in range(n):
            e -= p.C_meas[i] * x[i]
        v_hat = 0.0
        u_lin = 0.0
        v_star = 0.0
        for i in range(n):
            zi = x[i] + p.M[i] * e
            v_hat += p.C_v[i] * zi
            u_lin += p.C_u[i] * zi
            v_star += p.CvA[i] * zi
        f_k, _ = _friction(v_hat, F_N[k], p.mu, p.alpha)
        y[k, 0] = u_lin + p.D_u * f_k
        y[k, 1] = v_hat
        y[k, 2] = e
        y[k, 3] = f_k
        if variant == 0:
            v_next, it[k] = _implicit_v_v1(v_star, p.beta, F_N[k], p.mu, p.alpha)
        else:
            v_next, it[k] = _implicit_v_iter(v_star, p.beta, F_N[k], p.mu, p.alpha)
        f_next, _ = _friction(v_next, F_N[k], p.mu, p.alpha)
        for i in range(n):
            acc = p.B_dT[i] * f_next + p.L[i] * e
            for j in range(n):
                acc += p.A_d[i, j] * x[j]
            xn[i] = acc
        x[:] = xn


def _stats(it: np.ndarray) -> dict:
    return {"median": float(np.median(it)), "p99": float(np.percentile(it, 99)), "max": int(it.max()),
            "mean": float(it.mean()), "over_8": int((it > 8).sum())}


def measure(path) -> dict:
    """The two variants on the log at path (module docstring)."""
    from frictionrt.rt.export.replay_c import log_design
    from frictionrt.rt.loop.replay import SENSORS, logged_faults
    from frictionrt.rt.loop.supervisor import S_GOOD
    rec, meta, names, loop, st, _ = log_design(Path(path))
    if loop.estimator != "observer":
        raise ValueError(f"{path}: the estimator is {loop.estimator}, not the observer")
    if any(int(r[0]) == 6 for r in logged_faults(path, meta)):
        raise ValueError(f"{path}: an observer_mismatch fault acts on the observer's input; not supported here")
    v = np.ascontiguousarray(rec.log[:, names.index("v_tip_meas")])
    F = rec.log[:, names.index("F_cell")].copy()
    last = float(st.sv[S_GOOD + SENSORS.index("F_cell")])
    for i in range(len(F)):   # the supervisor's sanitiser: the last finite reading
        if np.isfinite(F[i]):
            last = F[i]
        else:
            F[i] = last
    ref = rec.log[:, [names.index(c) for c in ("u_rel_hat", "v_rel_hat", "innovation", "f_r_hat")]]
    out = {"file": str(path), "ticks": len(v), "kernel_version": logged_version(meta)}
    ys = {}
    for variant, name in ((0, "v1"), (1, "current")):
        y = np.empty((len(v), 4))
        it = np.zeros(len(v), dtype=np.int64)
        _run(st.xe.copy(), v, F, loop.observer, variant, y, it)
        ys[name] = y
        out[name] = _stats(it) | {"reproduces_log": bool((y.view(np.uint64) == ref.view(np.uint64)).all())}
    out["max_abs_diff_v_rel_hat"] = float(np.abs(ys["v1"][:, 1] - ys["current"][:, 1]).max())
    out["max_abs_diff_f_r_hat"] = float(np.abs(ys["v1"][:, 3] - ys["current"][:, 3]).max())
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("logs", nargs="+")
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    res = []
    for p in a.logs:
        r = measure(p)
        res.append(r)
        print(f"{p} ({r['ticks']} ticks, kernel version {r['kernel_version']})")
        for name in ("v1", "current"):
            s = r[name]
            print(f"  {name:<8} median {s['median']:>5.1f}  p99 {s['p99']:>5.1f}  max {s['max']:>3d}  "
                  f"mean {s['mean']:>6.2f}  ticks > 8: {s['over_8']:>6d}  reproduces log: {s['reproduces_log']}")
        print(f"  max |v_rel_hat v1 - current| {r['max_abs_diff_v_rel_hat']:.3g} m/s, "
              f"|f_r_hat| {r['max_abs_diff_f_r_hat']:.3g} N")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(res, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
