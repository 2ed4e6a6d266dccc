"""Step-time benchmarks of the compiled kernels (``frictionrt bench``, ``benchmarks/``).

Times are measured inside the compiled loop around each step (``frictionrt.rt.common.clock._now_ns``), so they
are the step's own cost without Python call overhead. Reported per case: median, p99, p99.9
and max [us] over the steps after a warm-up run, plus the 47.6 us budget share of the median.
The named alternative measured in the same process is python-control's ``forced_response`` of
the same reduced plant linearised with its preloaded pairs stuck, discretised with Tustin
(the linear part of our integrator); it has no contact law, so it is a lower bound on what a
general-purpose simulator costs per step, not a like-for-like replacement.
"""
from __future__ import annotations

import dataclasses
import time

import numba
import numpy as np

from frictionrt.plant.model import PlantModel, build_plant, preloaded_pairs, stuck_frequencies_hz, stuck_stiffness
from frictionrt.plant.simulate import run
from frictionrt.tracking.lowpass import _biquad_step, rest_state
from frictionrt.rt.common.clock import _now_ns
from frictionrt.rt.common.config import Config, Estimator
from frictionrt.tracking.force_tracking import _force_tracking_step
from frictionrt.tracking.force_tracking import initial_state as tracking_initial_state
from frictionrt.tracking.laws import _laws_step

BUDGET_US = 1e6 / 21000.0  # the controller step [us]


def _with_pairs(cfg: Config, n_pairs: int) -> Config:
    """``cfg`` with n_pairs contact points at a uniform pitch (end_refinement 1) over its interface."""
    itf = cfg.plant.interface
    pitch = (itf.x_end_m - itf.x_start_m) / (n_pairs - 1)
    plant = dataclasses.replace(cfg.plant, interface=dataclasses.replace(itf, pitch_m=pitch, end_refinement=1),
                                element_length_m=min(cfg.plant.element_length_m, pitch))
    return dataclasses.replace(cfg, plant=plant)


def _excitation(model: PlantModel, n_steps: int, amplitude: float = 5.0) -> np.ndarray:
    """Sine at the preloaded mode-3 frequency [N]: the pairs stick and slip every cycle."""
    f3 = stuck_frequencies_hz(model, preloaded_pairs(model))[2]
    return amplitude * np.sin(2 * np.pi * f3 * np.arange(n_steps) * model.cfg.dt_s)


def _stats_us(ns: np.ndarray) -> dict:
    us = ns / 1e3
    return {"median_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
            "p999_us": float(np.percentile(us, 99.9)), "max_us": float(us.max()), "mean_us": float(us.mean())}


def bench_case(cfg: Config, n_pairs: int, n_steps: int) -> dict:
    """Time the plant step for one pair count (reduced model, default substeps)."""
    model = build_plant(_with_pairs(cfg, n_pairs))
    F = _excitation(model, n_steps)
    fn1 = model.structure.F_N1_initial
    run(model, F[: min(2000, n_steps)], fn1)  # warm-up: compile or load the cache, touch memory
    Y, _, ns = run(model, F, fn1)
    out = _stats_us(ns)
    out.update({"n_modal": model.n, "newton_iter_mean": float(Y[:, model.output_index()["newton_iter"]].mean()),
                "budget_share_median": out["median_us"] / BUDGET_US})
    return out


def bench_alternative(cfg: Config, n_steps: int) -> dict:
    """python-control forced_response of the linearised (preloaded pairs stuck) reduced plant."""
    import control
    model = build_plant(cfg)
    p = model.params
    K = stuck_stiffness(model, preloaded_pairs(model))
    n = model.n
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -np.diag(p.c)]])
    B = np.concatenate([np.zeros(n), p.b_exc])[:, None]
    C = np.hstack([p.out_rows, np.zeros_like(p.out_rows)])
    sysd = control.c2d(control.ss(A, B, C, 0), cfg.dt_s, method="tustin")
    F = _excitation(model, n_steps)
    T = np.arange(n_steps) * cfg.dt_s
    t0 = time.perf_counter()
    control.forced_response(sysd, T, F)
    per_step = (time.perf_counter() - t0) / n_steps * 1e6
    return {"name": "python-control forced_response, linearised reduced plant, Tustin", "per_step_us": per_step,
            "n_states": 2 * n}


def bench_plant(cfg: Config, pairs=(5, 9, 17, 33), n_steps: int = 21000, progress: bool = True) -> dict:
    """Benchmark JSON: by_pairs -> str(P) -> {median_us, p99_us, p999_us, max_us, ...}; alternative."""
    from tqdm import tqdm
    by_pairs = {}
    for P in tqdm(list(pairs), desc="plant step", unit="case", disable=not progress):
        by_pairs[str(P)] = bench_case(cfg, P, n_steps)
    return {"steps": n_steps, "budget_us": BUDGET_US, "by_pairs": by_pairs,
            "alternative": bench_alternative(cfg, n_steps)}


def format_table(res: dict) -> str:
    lines = [f"plant step over {res['steps']} steps (budget {res['budget_us']:.1f} us)",
             f"{'pairs':>5} {'n':>4} {'median':>8} {'p99':>8} {'p99.9':>8} {'max':>9} {'Newton it':>9}  [us]"]
    for P, r in res["by_pairs"].items():
        lines.append(f"{P:>5} {r['n_modal']:>4} {r['median_us']:>8.2f} {r['p99_us']:>8.2f} {r['p999_us']:>8.2f} "
                     f"{r['max_us']:>9.1f} {r['newton_iter_mean']:>9.3f}")
    alt = res["alternative"]
    lines.append(f"alternative: {alt['name']} ({alt['n_states']} states): {alt['per_step_us']:.2f} us/step")
    return "\n".join(lines)


# --- the loop's controller part against python-control ---------------------------------------

@numba.njit(cache=True, nogil=True)
def _controller_run(U, orc_p, law_p, pre_p, ft_p, X0, V, step_ns):
    """The controller part of a tick (oracle filter, law + RT1, setpoint prefilter, force
    tracking) over the rows of U = (u_rel [m], v_rel [m/s], F_meas [N]); V_cmd [V] into V.
    X0 = (oracle 4, law 1, prefilter 2, tracking 3) initial states."""
    xo, xl, xq, xf = X0[0:4].copy(), X0[4:5].copy(), X0[5:7].copy(), X0[7:10].copy()
    xo_n, xl_n, xq_n, xf_n = np.empty(4), np.empty(1), np.empty(2), np.empty(3)
    yo, yl, yq, yf = np.empty(2), np.empty(2), np.empty(1), np.empty(2)
    uq, uf = np.empty(1), np.empty(2)
    ts = np.zeros(2, dtype=np.int64)
    for k in range(U.shape[0]):
        t0 = _now_ns(ts)
        _biquad_step(k, xo, U[k, 0:2], orc_p, xo_n, yo)
        _laws_step(k, xl, yo, law_p, xl_n, yl)
        uq[0] = yl[0]
        _biquad_step(k, xq, uq, pre_p, xq_n, yq)
        uf[0] = yq[0]
        uf[1] = U[k, 2]
        _force_tracking_step(k, xf, uf, ft_p, xf_n, yf)
        V[k] = yf[0]
        xo[:] = xo_n
        xl[:] = xl_n
        xq[:] = xq_n
        xf[:] = xf_n
        step_ns[k] = _now_ns(ts) - t0


def _controller_inputs(cfg: Config, n: int) -> np.ndarray:
    """u_rel, v_rel of a 223.6 Hz slip of 2 um and a measured force around 60 N."""
    t = np.arange(n) * cfg.dt_s
    w = 2 * np.pi * 223.6
    return np.column_stack([2e-6 * np.sin(w * t), 2e-6 * w * np.cos(w * t), 60.0 + 5.0 * np.sin(w * t)])


def bench_loop(cfg: Config, law: str = "lyapunov", n_steps: int = 21000, n_pc: int = 2000) -> dict:
    """Whole-tick figures of the loop and its controller part against python-control's
    nlsys + input_output_response of the same discrete controller (same step functions).

    JSON: total -> median_us, p99_us, p999_us, max_us (whole tick); controller -> ...;
    python_control_us_per_step; speedup (python-control / compiled controller, per step);
    max_abs_diff_v (V_cmd of both over the python-control run) [V].
    """
    import control

    from frictionrt.rt.loop.budget import EXC_AMP_N, EXC_FREQ_HZ
    from frictionrt.rt.loop.build import build_loop
    from frictionrt.rt.loop.driver import run
    loop = build_loop(cfg, law, Estimator.ORACLE)
    run(loop, EXC_FREQ_HZ, EXC_AMP_N, 0.01)
    total = _stats_us(run(loop, EXC_FREQ_HZ, EXC_AMP_N, n_steps * cfg.dt_s).signal("tick_ns"))
    U = _controller_inputs(cfg, n_steps)
    X0 = np.concatenate([np.zeros(4), np.zeros(1), rest_state(loop.prefilter, (cfg.tracking.F_min_N,)),
                         tracking_initial_state(60.0)])
    parts = (loop.oracle, loop.law_params, loop.prefilter, loop.design.params)
    V, ns = np.empty(n_steps), np.empty(n_steps, dtype=np.int64)
    _controller_run(U[:10], *parts, X0, V[:10], ns[:10])
    _controller_run(U, *parts, X0, V, ns)
    ctrl = _stats_us(ns)

    def step(x, u):
        y = np.empty(2), np.empty(2), np.empty(1), np.empty(2)
        xn = np.empty(10)
        _biquad_step(0, x[0:4], u[0:2], loop.oracle, xn[0:4], y[0])
        _laws_step(0, x[4:5], y[0], loop.law_params, xn[4:5], y[1])
        _biquad_step(0, x[5:7], y[1][:1], loop.prefilter, xn[5:7], y[2])
        _force_tracking_step(0, x[7:10], np.array([y[2][0], u[2]]), loop.design.params, xn[7:10], y[3])
        return xn, y[3][0]

    sys = control.nlsys(lambda t, x, u, params: step(x, u)[0], lambda t, x, u, params: step(x, u)[1],
                        inputs=3, outputs=1, states=10, dt=cfg.dt_s, name="controller")
    T = np.arange(n_pc) * cfg.dt_s
    t0 = time.perf_counter()
    resp = control.input_output_response(sys, T, U[:n_pc].T, X0)
    pc_us = (time.perf_counter() - t0) / n_pc * 1e6
    return {"budget_us": BUDGET_US, "law": law, "total": total, "controller": ctrl,
            "python_control_us_per_step": pc_us, "speedup": pc_us / ctrl["mean_us"],
            "max_abs_diff_v": float(np.max(np.abs(np.asarray(resp.outputs).ravel() - V[:n_pc])))}


def format_loop(res: dict) -> str:
    t, c = res["total"], res["controller"]
    return "\n".join([
        f"loop tick ({res['law']}): median {t['median_us']:.2f} us, p99 {t['p99_us']:.2f}, p99.9 {t['p999_us']:.2f}, "
        f"max {t['max_us']:.1f} (budget {res['budget_us']:.1f} us)",
        f"controller part: median {c['median_us']:.3f} us, mean {c['mean_us']:.3f} us; python-control nlsys + "
        f"input_output_response: {res['python_control_us_per_step']:.1f} us/step ({res['speedup']:.0f}x), "
        f"max |V_cmd difference| {res['max_abs_diff_v']:.2e} V"])
