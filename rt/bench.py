"""Step-time benchmarks of the compiled kernels (``frictionrt bench``, ``benchmarks/``).

Times are measured inside the compiled loop around each step (``rt.clock._now_ns``), so they
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

import numpy as np

from plant.model import PlantModel, build_plant, preloaded_pairs, stuck_frequencies_hz, stuck_stiffness
from plant.simulate import run
from rt.config import Config

BUDGET_US = 1e6 / 21000.0  # the controller step [us]


def _with_pairs(cfg: Config, n_pairs: int) -> Config:
    itf = cfg.plant.interface
    pitch = (itf.x_end_m - itf.x_start_m) / (n_pairs - 1)
    plant = dataclasses.replace(cfg.plant, interface=dataclasses.replace(itf, pitch_m=pitch),
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
