"""The timing budget of the loop (``frictionrt budget``): per-component tick times offline, then
a paced run with overruns, lateness and drift, next to what the machine allows at the same
period, priority and core (rt/loop/floor.py): the null loop (the same pacing, an empty tick)
and, when installed, cyclictest. Budget: one controller step, 1/21000 s."""
from __future__ import annotations

import numpy as np

from frictionrt.rt.common.config import DEFAULT_ESTIMATOR, Config
from frictionrt.rt.loop.build import COMPONENTS, build_loop
from frictionrt.rt.loop.floor import cyclictest, null_loop, tails_us
from frictionrt.rt.loop.driver import run

EXC_FREQ_HZ, EXC_AMP_N = 223.6, 5.0  # mode-3 resonance, moderate amplitude: stick-slip every cycle


def _stats(ns: np.ndarray) -> dict:
    us = np.asarray(ns, dtype=float) / 1e3
    return {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
            "p999_us": float(np.percentile(us, 99.9)), "max_us": float(us.max())}


def budget(cfg: Config, law: str = "lyapunov", ticks: int = 105000, paced_s: float = 5.0, floor: bool = True,
           estimator: str = DEFAULT_ESTIMATOR) -> dict:
    """The loop of ``law`` on ``estimator`` ("observer", the default as in ``frictionrt simulate``, or
    "oracle"). JSON: budget_us, law, estimator; components -> name -> median_us, p99_us, p999_us,
    max_us; total; paced -> ticks, overruns, overrun_rate, late (p50_us, p99_us, p999_us, max_us), drift_us, realtime;
    with ``floor``, null (the null loop: ticks, overruns, overrun_rate, late, realtime) and
    cyclictest (loops, late_ge_period, late_rate, latency; None when not installed), each run
    for paced_s [s] under the same configuration (rt.priority, rt.cpu, the sleep margin)."""
    loop = build_loop(cfg, law, estimator)
    dt = cfg.dt_s
    run(loop, EXC_FREQ_HZ, EXC_AMP_N, 0.01, timing=True)  # compile or load the cache
    r = run(loop, EXC_FREQ_HZ, EXC_AMP_N, ticks * dt, timing=True)
    comps = {name: _stats(r.comp_ns[:, i]) for i, name in enumerate(COMPONENTS)}
    total = _stats(r.signal("tick_ns"))
    p = run(loop, EXC_FREQ_HZ, EXC_AMP_N, paced_s, paced=True)
    late = p.signal("late_ns")
    n_p = len(late) + p.overruns  # ticks the wall clock allowed for
    drift_us = (p.wall_ns - n_p * dt * 1e9) / 1e3
    res = {"budget_us": dt * 1e6, "law": law, "estimator": estimator, "ticks": len(r.log), "components": comps, "total": total,
           "paced": {"ticks": len(late), "overruns": p.overruns, "overrun_rate": p.overruns / n_p,
                     "late": tails_us(late), "drift_us": float(drift_us),
                     "tick_median_us": float(np.median(p.signal("tick_ns")) / 1e3), "realtime": p.realtime}}
    if floor:
        res["null"] = null_loop(cfg.rt, dt, paced_s)
        res["cyclictest"] = cyclictest(cfg.rt, dt, paced_s)
    return res


def format_budget(res: dict) -> str:
    lines = [f"tick budget {res['budget_us']:.3f} us; law {res['law']}, estimator {res.get('estimator', 'oracle')}; "
             f"{res['ticks']} ticks offline",
             f"{'component':>10} {'median':>8} {'p99':>8} {'p99.9':>8} {'max':>9}  [us]"]
    for name, s in [*res["components"].items(), ("total", res["total"])]:
        lines.append(f"{name:>10} {s['median_us']:>8.3f} {s['p99_us']:>8.3f} {s['p999_us']:>8.3f} {s['max_us']:>9.1f}")
    p = res["paced"]
    lines.append(f"paced: drift {p['drift_us']:.1f} us, tick median {p['tick_median_us']:.2f} us; "
                 f"{_realtime_text(p['realtime'])}")
    rows = [("paced loop", p["ticks"], p["overruns"], p["overrun_rate"], p["late"])]
    if "null" in res:
        n = res["null"]
        rows.append(("null loop", n["ticks"], n["overruns"], n["overrun_rate"], n["late"]))
    lines.append(f"{'':>12} {'ticks':>8} {'missed':>7} {'rate %':>8} {'late p50':>9} {'p99':>7} {'p99.9':>7} "
                 f"{'max':>8}  [us]")
    for name, n_t, n_o, rate, lt in rows:
        lines.append(f"{name:>12} {n_t:>8} {n_o:>7} {100 * rate:>8.4f} {lt['p50_us']:>9.2f} {lt['p99_us']:>7.2f} "
                     f"{lt['p999_us']:>7.2f} {lt['max_us']:>8.1f}")
    c = res.get("cyclictest", "absent")
    if c is None:
        lines.append("  cyclictest: not installed (Debian: apt install rt-tests) - the machine's floor is the null loop's")
    elif isinstance(c, dict) and "error" in c:
        lines.append(f"  cyclictest failed: {' '.join(c['error'])} ({c['command']})")
    elif isinstance(c, dict):
        lt = c["latency"]
        lines.append(f"{'cyclictest':>12} {c['loops']:>8} {c['late_ge_period']:>7} {100 * c['late_rate']:>8.4f} "
                     f"{lt['p50_us']:>9.2f} {lt['p99_us']:>7.2f} {lt['p999_us']:>7.2f} {lt['max_us']:>8.1f}"
                     f"  (wake-up latency, -i {c['interval_us']} us; missed: latency >= one period)")
    return "\n".join(lines)


def _realtime_text(rt: dict | None) -> str:
    """One line: what the paced run's real-time set-up got (rt/loop/realtime.py)."""
    if rt is None:
        return "no real-time set-up"
    parts = [f"SCHED_FIFO {rt['priority']}" if rt["priority"] else "default scheduler",
             f"core {rt['cpu']}" if rt["cpu"] >= 0 else "not pinned",
             f"sleep margin {rt['sleep_margin_us']:g} us",
             "memory locked" if rt["memory_locked"] else "memory not locked",
             "cpu_dma_latency 0" if rt["dma_latency_held"] else "no cpu_dma_latency"]
    return ", ".join(parts)
