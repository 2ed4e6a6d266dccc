"""The timing budget of the loop (``frictionrt budget``): per-component tick times offline, then
a paced run with overruns, lateness and drift. Budget: one controller step, 1/21000 s."""
from __future__ import annotations

import numpy as np

from rt.common.config import Config
from rt.loop.build import COMPONENTS, build_loop
from rt.loop.driver import run

EXC_FREQ_HZ, EXC_AMP_N = 223.6, 5.0  # mode-3 resonance, moderate amplitude: stick-slip every cycle


def _stats(ns: np.ndarray) -> dict:
    us = np.asarray(ns, dtype=float) / 1e3
    return {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
            "p999_us": float(np.percentile(us, 99.9)), "max_us": float(us.max())}


def budget(cfg: Config, law: str = "lyapunov", ticks: int = 105000, paced_s: float = 5.0) -> dict:
    """JSON: budget_us; components -> name -> median_us, p99_us, p999_us, max_us; total; paced ->
    ticks, overruns, late_p99_us, late_max_us, drift_us."""
    loop = build_loop(cfg, law)
    dt = cfg.dt_s
    run(loop, EXC_FREQ_HZ, EXC_AMP_N, 0.01, timing=True)  # compile or load the cache
    r = run(loop, EXC_FREQ_HZ, EXC_AMP_N, ticks * dt, timing=True)
    comps = {name: _stats(r.comp_ns[:, i]) for i, name in enumerate(COMPONENTS)}
    total = _stats(r.signal("tick_ns"))
    p = run(loop, EXC_FREQ_HZ, EXC_AMP_N, paced_s, paced=True)
    late = p.signal("late_ns")
    n_p = len(late) + p.overruns  # ticks the wall clock allowed for
    drift_us = (p.wall_ns - n_p * dt * 1e9) / 1e3
    return {"budget_us": dt * 1e6, "law": law, "ticks": len(r.log), "components": comps, "total": total,
            "paced": {"ticks": len(late), "overruns": p.overruns,
                      "late_p99_us": float(np.percentile(late, 99) / 1e3),
                      "late_max_us": float(late.max() / 1e3), "drift_us": float(drift_us),
                      "tick_median_us": float(np.median(p.signal("tick_ns")) / 1e3)}}


def format_budget(res: dict) -> str:
    lines = [f"tick budget {res['budget_us']:.3f} us; law {res['law']}; {res['ticks']} ticks offline",
             f"{'component':>10} {'median':>8} {'p99':>8} {'p99.9':>8} {'max':>9}  [us]"]
    for name, s in [*res["components"].items(), ("total", res["total"])]:
        lines.append(f"{name:>10} {s['median_us']:>8.3f} {s['p99_us']:>8.3f} {s['p999_us']:>8.3f} {s['max_us']:>9.1f}")
    p = res["paced"]
    lines.append(f"paced: {p['ticks']} ticks, {p['overruns']} overruns, lateness p99 {p['late_p99_us']:.2f} us, "
                 f"max {p['late_max_us']:.1f} us, drift {p['drift_us']:.1f} us, "
                 f"tick median {p['tick_median_us']:.2f} us")
    return "\n".join(lines)
