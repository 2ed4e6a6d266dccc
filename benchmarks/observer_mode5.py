"""Where the observer's mode-5 u0 error comes from: one closed-loop run per amplitude (the hysteresis
law on the paper's observer at mode 5's passive step-sine peak), then observer variants run offline
on that run's logged inputs (the sensor chain's tip velocity and the force cell), so every variant
sees the same plant truth.

    python -m benchmarks.observer_mode5 [--amps 5 10] [--duration 0.5] [--json OUT.json]
    python -m benchmarks.observer_mode5 --in-loop 0.1 [--amps 5 10] [--kind amplitude]   # closed loop, modes 2-5
    python -m benchmarks.observer_mode5 --fit-scales [--amps 5 10]   # the scale that fits each amplitude's peaks

Per amplitude it prints, over the last 20 % of the run (``frictionrt.observer.accuracy.TAIL``):

* the sensor chain: |V_meas / V_tip| and its phase at the excitation (phasors, ``observer.offline.phasor``);
* the transfer ratio rho = U_rel / V_tip (complex, [s]) of the plant's truth, of the estimate
  (U_rel_hat / V_meas), of the observer's linear model at the excitation with the joint free
  (``model_ratio``; all modes, and mode 5 alone), of the plant's own reduced model linearised at
  F_min with the adaptive joint sliding and stuck (``plant_ratio``), and of that sliding
  linearisation driven by the run's own excitation and joint friction (the cone pairs' tangential
  contact forces, ``forced_ratio``): the observer is driven by v_tip alone, so a model with the
  right velocity makes the u0 error |rho_model| / |rho_true| - 1;
* the joint friction's first harmonic: the plant's (the cone pairs' f_t) and the observer's f_r_hat;
* per variant run offline (``variant_outputs``: the run-time kernels, tick by tick on the logged
  inputs; "paper" reproduces the loop's own estimate, which the script checks) the u0 error
  mean((pi/2)|u_hat|) / mean((pi/2)|u_true|) - 1, |U_hat| / |U_true| - 1, |Y_hat| / |Y| - 1 of the
  model's tip velocity against its input, NRMSE(v_rel) and the first harmonic of its friction
  force: "no D_u" (the static correction removed), "N=20" (20 modes kept instead of 7, the gain
  redesigned), "f5 at f" (mode 5's frequency moved onto the excitation: the amplitude kind's step
  with mode 5 scheduled at that ratio), "jenkins" (the joint as a Jenkins element), "amplitude kind"
  (the kind as it runs), "alpha A" (the friction law's regularisation, up to a nearly hard
  Coulomb force), and the paper's observer fed the plant's own tip velocity (no sensor chain) and
  that velocity one tick late.

The loop's law acts on the paper's estimate in every row; the variants only estimate.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.entry import run_main

FREQ_HZ = 615.87   # mode 5's passive step-sine peak at 5 and 10 N (the full reproduction's)
MODE = 5
SPRING_SCALES = (0.5, 0.3, 0.2, 0.1)   # the model's normal springs under the adaptive screw, x k_n_area
ALPHAS = (300.0, 1000.0, 3000.0, 10000.0)   # friction regularisations tried [s/m] (the default: observer.alpha_s_m)


def model_ratio(model, f_hz: float, modes=None) -> complex:
    """U_rel / V_tip [s] of the observer's linear model driven by the excitation force at f_hz with
    the joint free (f_r = 0): sum_i t phi_i g_i / (i w sum_i p phi_i g_i),
    g_i = phi_i^T b_exc / (w_i^2 - w^2 + 2 i zeta w_i w); ``modes`` (0-based) restricts the sums."""
    N = len(model.omega)
    w = 2 * np.pi * f_hz
    b = model.B_F[N:]
    g = b / (model.omega ** 2 - w ** 2 + 2j * model.zeta * model.omega * w)
    keep = np.arange(N) if modes is None else np.asarray(modes)
    return complex(np.sum(model.C_u[:N][keep] * g[keep]) / (1j * w * np.sum(model.C_meas[N:][keep] * g[keep])))


def _linearised_stiffness(plant, F_N1: float, sliding: bool, free_rows: np.ndarray | None = None) -> np.ndarray:
    """diag(omega^2) + G^T K_c G [1/s^2] of the plant's reduced model with the pairs closed at F_N1
    stuck (k_n, k_t), the adaptive screw's cone pairs tangentially free if ``sliding``, and the contact
    rows ``free_rows`` ((2p,) bool) without stiffness."""
    from frictionrt.plant.model import preloaded_pairs
    from frictionrt.plant.structure import adaptive_cone_pairs
    p = plant.params
    closed = preloaded_pairs(plant, F_N1)
    cone = adaptive_cone_pairs(plant.cfg, plant.structure.x_pairs)
    k_all = np.zeros(p.G.shape[0])
    k_all[0::2] = p.k_n * closed
    k_all[1::2] = p.k_t * (closed & ~cone if sliding else closed)
    if free_rows is not None:
        k_all[free_rows] = 0.0
    return np.diag(p.omega2) + (p.G.T * k_all) @ p.G


def plant_ratio(plant, f_hz: float, joint: str, F_N1: float) -> complex:
    """U_rel / V_tip [s] of the plant's reduced model linearised at F_N1 (the closed pairs stuck;
    ``joint`` "sliding": the adaptive screw's cone pairs tangentially free, "stuck": not), driven
    by the excitation force at f_hz, with the model's own modal damping."""
    p = plant.params
    st = plant.structure
    w = 2 * np.pi * f_hz
    K = _linearised_stiffness(plant, F_N1, joint == "sliding")
    q = np.linalg.solve(K - w * w * np.eye(len(p.omega2)) + 1j * w * np.diag(p.c), plant.Phi.T @ st.b_exc)
    tip = st.point_rows[list(st.point_names).index("tip")] @ plant.Phi
    return complex((st.u_rel_row @ plant.Phi) @ q / (1j * w * (tip @ q)))


def forced_ratio(plant, f_hz: float, F_N1: float, F_exc: complex, lam: np.ndarray, true_rows: np.ndarray) -> complex:
    """U_rel / V_tip [s] of the plant's reduced model linearised at F_N1 with the adaptive joint
    sliding (``plant_ratio``), driven at f_hz by the run's excitation phasor F_exc [N] and, on the
    contact rows ``true_rows`` ((2p,) bool, g_n and g_t interleaved), by the run's own contact forces
    ``lam`` ((2p,) phasors [N], modal force G^T Lambda) in place of their linearised stiffness:
    what the linear structure gives with those forces the plant's own."""
    p = plant.params
    st = plant.structure
    w = 2 * np.pi * f_hz
    K = _linearised_stiffness(plant, F_N1, True, true_rows)
    load = plant.Phi.T @ st.b_exc * F_exc + p.G[true_rows].T @ lam[true_rows]
    q = np.linalg.solve(K - w * w * np.eye(len(p.omega2)) + 1j * w * np.diag(p.c), load)
    tip = st.point_rows[list(st.point_names).index("tip")] @ plant.Phi
    return complex((st.u_rel_row @ plant.Phi) @ q / (1j * w * (tip @ q)))


def variant_outputs(params, amp, v_meas: np.ndarray, F_N: np.ndarray) -> tuple[np.ndarray, ...]:
    """(u_rel_hat, v_rel_hat, y_hat, f_r_hat) of the run-time observer step (the paper's, or the amplitude
    kind's when ``amp`` has a grid) run tick by tick from z = 0 on the inputs (v_meas, F_N);
    y_hat = C_meas z_k|k, the model's tip velocity; f_r_hat the friction force its law gives [N]."""
    from frictionrt.observer.amplitude_step import _amplitude_step
    from frictionrt.observer.step import _observer_step
    n = len(v_meas)
    nz = params.M.shape[0] + (1 if len(amp.grid) and amp.k_j > 0.0 else 0)
    x, xn = np.zeros(nz), np.zeros(nz)
    y, u, wk = np.zeros(4), np.zeros(2), np.zeros(nz)
    out = np.zeros((n, 4))
    C = params.C_meas
    for k in range(n):
        u[0], u[1] = v_meas[k], F_N[k]
        if len(amp.grid):
            _amplitude_step(k, x, u, params, amp, wk, xn, y)
        else:
            _observer_step(k, x, u, params, xn, y)
        # z_k|k = x + M e, e = innovation
        out[k] = y[0], y[1], float(C @ (x[:len(C)] + params.M * y[2])), y[3]
        x, xn = xn, x
    return out[:, 0], out[:, 1], out[:, 2], out[:, 3]


def one(amp_n: float, duration: float) -> dict:
    from frictionrt.observer.accuracy import TAIL, at_estimate_instant, band_limited_truth, nrmse
    from frictionrt.observer.amplitude import design_amplitude, no_amplitude
    from frictionrt.observer.kalman import design_observer
    from frictionrt.observer.offline import phasor
    from frictionrt.plant.model import build_plant
    from frictionrt.plant.structure import adaptive_cone_pairs
    from frictionrt.rt.common.config import load, with_sets
    from frictionrt.rt.loop import build_loop, run, summary

    cfg = load()
    plant = build_plant(cfg)
    design = design_observer(cfg, plant)
    r = run(build_loop(cfg, "hysteresis", "observer"), FREQ_HZ, amp_n, duration)
    s = summary(r)
    dt, f_c, f = cfg.dt_s, cfg.observer.oracle_bandwidth_hz, FREQ_HZ
    u_true = band_limited_truth(r.signal("u_rel"), dt, f_c)
    v_true = band_limited_truth(r.signal("v_rel"), dt, f_c)
    v_meas, F = r.signal("v_tip_meas"), r.signal("F_cell")
    n = len(u_true)
    tail = slice(n - max(int(TAIL * n), 2), n)
    ph = {name: phasor(x, f, dt) for name, x in (("u_true", u_true), ("v_tip", r.signal("v_tip")),
                                                   ("v_meas", v_meas), ("u_hat", r.signal("u_rel_hat")))}
    F_N1 = float(np.mean(r.signal("F_N1")[tail]))
    ratios = {"truth": ph["u_true"] / ph["v_tip"], "estimate": ph["u_hat"] / ph["v_meas"],
              "model": model_ratio(design.model, f), "model mode 5 only": model_ratio(design.model, f, [MODE - 1]),
              "plant sliding": plant_ratio(plant, f, "sliding", cfg.tracking.F_min_N),
              "plant stuck": plant_ratio(plant, f, "stuck", cfg.tracking.F_min_N)}
    n_p = plant.n_pairs
    cone = adaptive_cone_pairs(cfg, plant.structure.x_pairs)
    lam = np.zeros(2 * n_p, complex)
    lam[0::2] = [phasor(r.signal(f"f_n_{j}"), f, dt) for j in range(n_p)]
    lam[1::2] = [phasor(r.signal(f"f_t_{j}"), f, dt) for j in range(n_p)]
    F_exc = phasor(r.signal("F_exc"), f, dt)
    joint = np.zeros(2 * n_p, bool)
    joint[1::2] = cone
    ratios["plant sliding + its joint friction"] = forced_ratio(plant, f, cfg.tracking.F_min_N, F_exc, lam, joint)
    ft = lam[1::2][cone]
    fr_hat = phasor(r.signal("f_r_hat"), f, dt)
    friction = {"true_cone_sum_abs_N": abs(ft.sum()), "hat_abs_N": abs(fr_hat),
                "true_phase_deg": float(np.degrees(np.angle(ft.sum() / F_exc))),
                "hat_phase_deg": float(np.degrees(np.angle(fr_hat / F_exc))), "F_exc_abs_N": abs(F_exc)}
    row = {"amp_n": amp_n, "freq_hz": f, "duration_s": duration, "u0_error_law": s["u0_rel_error"],
           "F_N1_mean_tail_N": F_N1, "sensor_gain": abs(ph["v_meas"] / ph["v_tip"]),
           "sensor_phase_deg": float(np.degrees(np.angle(ph["v_meas"] / ph["v_tip"]))),
           "model_hz": float(design.model.modes_hz[MODE - 1]), "friction": friction}
    none = no_amplitude(len(design.model.omega))
    variants = {"paper": (design.params, none)}
    p = design.params
    variants["no D_u"] = (p._replace(D_u=0.0), none)
    variants["N=20"] = (design_observer(with_sets(cfg, ["observer.n_modes=20"]), plant).params, none)
    r5 = f / row["model_hz"]
    d5, a5 = design_amplitude(cfg, plant, peaks={MODE: ((1e-12, r5),)})
    variants["f5 at f"] = (d5.params, a5)
    dj, aj = design_amplitude(cfg, plant, peaks={}, jenkins=True)
    variants["jenkins"] = (dj.params, aj)
    da, aa = design_amplitude(cfg, plant)
    variants["amplitude kind"] = (da.params, aa)
    row["spring_scale_modes_hz"] = {}
    for scale in SPRING_SCALES:
        ds = design_observer(cfg, plant, spring_scale=scale)
        variants[f"normal springs x {scale:g}"] = (ds.params, none)
        row["spring_scale_modes_hz"][f"{scale:g}"] = [round(float(x), 2) for x in ds.model.modes_hz[1:5]]
        ratios[f"model, normal springs x {scale:g}"] = model_ratio(ds.model, f)
    for alpha in ALPHAS:
        variants[f"alpha {alpha:g}"] = (p._replace(alpha=alpha), none)
    v_tip = r.signal("v_tip")
    inputs = {name: v_meas for name in variants}
    variants["paper, fed the plant's v_tip"] = (p, none)
    inputs["paper, fed the plant's v_tip"] = v_tip
    variants["paper, fed v_tip one tick later"] = (p, none)
    inputs["paper, fed v_tip one tick later"] = np.concatenate([[0.0], v_tip[:-1]])
    row["variants"] = {}
    for name, (params, amp) in variants.items():
        u_hat, v_hat, y_hat, f_hat = variant_outputs(params, amp, inputs[name], F)
        if name == "paper":
            row["paper_reproduces_loop_max_abs_m"] = float(np.max(np.abs(u_hat - r.signal("u_rel_hat"))))
        row["variants"][name] = {
            "f_r_first_harmonic_N": abs(phasor(f_hat, f, dt)),
            "u0_error": float(np.mean(np.abs(u_hat[tail])) / np.mean(np.abs(u_true[tail])) - 1.0),
            "U1_error": abs(phasor(u_hat, f, dt)) / abs(ph["u_true"]) - 1.0,
            "Y1_error": abs(phasor(y_hat, f, dt)) / abs(phasor(inputs[name], f, dt)) - 1.0,
            "v_rel_nrmse": nrmse(*at_estimate_instant(v_hat, v_true))}
    row["ratio_abs_s"] = {k: abs(v) for k, v in ratios.items()}
    row["ratio_phase_deg"] = {k: float(np.degrees(np.angle(v))) for k, v in ratios.items()}
    return row


PEAKS_HZ = {(2, 5.0): 70.77, (2, 10.0): 70.62, (3, 5.0): 200.77, (3, 10.0): 199.14,
            (4, 5.0): 374.97, (4, 10.0): 370.20, (5, 5.0): 615.87, (5, 10.0): 615.87,
            (4, 20.0): 369.00, (5, 20.0): 610.86}   # passive step-sine peaks (the full reproduction's)


def in_loop(mode: int, amp_n: float, scale: float, duration: float, kind: str = "observer",
            law: str = "hysteresis") -> dict:
    """The law (hysteresis by default) in the closed loop on the estimator ``kind`` (the paper's observer or the
    amplitude kind, ``design_amplitude(spring_scale=scale)``) designed with its normal springs at
    ``scale`` k_n_area (the law acts on that estimate), at mode's passive peak ``PEAKS_HZ``:
    NRMSE(v_rel), the law's u0 error, the first-harmonic tip acceleration at 0.45 m [m/s^2], the
    model's mode frequency."""
    import dataclasses
    from frictionrt.observer.amplitude import design_amplitude
    from frictionrt.observer.kalman import design_observer
    from frictionrt.rt.common.config import load
    from frictionrt.rt.loop import build_loop, run, summary
    cfg = load()
    loop = build_loop(cfg, law, kind)
    if kind == "amplitude":
        d, amp = design_amplitude(cfg, loop.plant, spring_scale=scale)
        loop = dataclasses.replace(loop, observer=d.params, amplitude=amp)
    else:
        d = design_observer(cfg, loop.plant, spring_scale=scale)
        loop = dataclasses.replace(loop, observer=d.params)
    s = summary(run(loop, PEAKS_HZ[(mode, amp_n)], amp_n, duration))
    return {"mode": mode, "amp_n": amp_n, "scale": scale, "model_hz": float(d.model.modes_hz[mode - 1]),
            "v_rel_nrmse": s["v_rel_nrmse"], "u0_error_law": s["u0_rel_error"], "acc045": s["acc045_amplitude"],
            "law": law}


def fitted_scales(amps=(5.0, 10.0), scales=None) -> list[dict]:
    """Per amplitude, the spring scale (of a geometric grid over [0.02, 0.2]) whose model puts modes
    3-5 nearest the passive peaks ``PEAKS_HZ`` at that amplitude (least rms relative error), its modes
    and its U_rel / V_tip at mode 5's peak (``model_ratio``): the points of a scale scheduled against
    the amplitude."""
    from frictionrt.observer.model import build_observer_model
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.common.config import load
    cfg = load()
    plant = build_plant(cfg)
    scales = np.geomspace(0.02, 0.2, 25) if scales is None else np.asarray(scales)
    models = {float(s): build_observer_model(cfg, plant, float(s)) for s in scales}
    out = []
    for amp in amps:
        peaks = np.array([PEAKS_HZ[(m, amp)] for m in (3, 4, 5)])
        err = {s: float(np.sqrt(np.mean((m.modes_hz[2:5] / peaks - 1) ** 2))) for s, m in models.items()}
        best = min(err, key=err.get)
        out.append({"amp_n": amp, "scale": best, "rms_error": err[best], "peaks_hz": peaks.tolist(),
                    "modes_hz": models[best].modes_hz[2:5].tolist(),
                    "ratio_us": 1e6 * abs(model_ratio(models[best], FREQ_HZ))})
    return out


def plant_ratios(amps=(5.0, 10.0), duration: float = 1.0, scale: float = 0.1) -> list[dict]:
    """The points of ``frictionrt.observer.amplitude.PLANT_RATIOS``: per amplitude, the hysteresis law at mode 5's
    passive peak at that amplitude (``PEAKS_HZ``) on the amplitude kind at spring scale ``scale`` without a participation
    (``ratios={}``); the first harmonics over the last 20 % of u_rel's band-limited truth U_rel, of the
    measured tip velocity V_meas (the observer's input) and of the plant's v_tip: U_rel [m],
    rho = U_rel / V_meas [s] (and U_rel / V_tip), and the law's u0 error on that estimate, and the frequency f_hz."""
    import dataclasses
    from frictionrt.observer.accuracy import band_limited_truth
    from frictionrt.observer.amplitude import design_amplitude
    from frictionrt.observer.offline import phasor
    from frictionrt.rt.common.config import load, with_sets
    from frictionrt.rt.loop import build_loop, run, summary
    cfg = with_sets(load(), [f"observer.spring_scale={scale!r}"])
    out = []
    for amp_n in amps:
        loop = build_loop(cfg, "hysteresis", "amplitude")
        loop = dataclasses.replace(loop, amplitude=design_amplitude(cfg, loop.plant, ratios={})[1])
        f_hz = PEAKS_HZ[(MODE, amp_n)]
        r = run(loop, f_hz, amp_n, duration)
        dt = cfg.dt_s
        U = abs(phasor(band_limited_truth(r.signal("u_rel"), dt, cfg.observer.oracle_bandwidth_hz), f_hz, dt))
        out.append({"amp_n": amp_n, "f_hz": f_hz, "U_rel_m": U, "rho_meas_s": U / abs(phasor(r.signal("v_tip_meas"), f_hz, dt)),
                    "rho_tip_s": U / abs(phasor(r.signal("v_tip"), f_hz, dt)),
                    "u0_error_law": summary(r)["u0_rel_error"]})
    return out


def format_rows(row: dict) -> list[str]:
    out = [f"F = {row['amp_n']:g} N at {row['freq_hz']} Hz (model mode 5 {row['model_hz']:.2f} Hz), "
           f"law's u0 error {100 * row['u0_error_law']:+.1f} %, F_N1 tail mean {row['F_N1_mean_tail_N']:.0f} N, "
           f"sensor |V_meas/V_tip| {row['sensor_gain']:.4f} at {row['sensor_phase_deg']:+.2f} deg, "
           f"offline 'paper' vs loop max |du| {row['paper_reproduces_loop_max_abs_m']:.2g} m",
           "| U_rel / V_tip | abs [us] | phase [deg] | vs truth |", "| --- | --- | --- | --- |"]
    t = row["ratio_abs_s"]["truth"]
    for k, a in row["ratio_abs_s"].items():
        out.append(f"| {k} | {1e6 * a:.3f} | {row['ratio_phase_deg'][k]:+.1f} | {100 * (a / t - 1):+.1f} % |")
    out.append("model modes 2-5 [Hz] with the normal springs scaled: " + "; ".join(
        f"x {k}: {', '.join(f'{x:.1f}' for x in v)}" for k, v in row["spring_scale_modes_hz"].items()))
    fr = row["friction"]
    out += [f"joint friction, first harmonic: plant (cone pairs' f_t) {fr['true_cone_sum_abs_N']:.2f} N, "
            f"observer in the loop {fr['hat_abs_N']:.2f} N", "",
            "| variant | u0 error | first-harmonic U error | model tip velocity error | NRMSE v_rel | f_r first harmonic [N] |",
            "| --- | --- | --- | --- | --- | --- |"]
    for k, v in row["variants"].items():
        out.append(f"| {k} | {100 * v['u0_error']:+.1f} % | {100 * v['U1_error']:+.1f} % | {100 * v['Y1_error']:+.1f} % "
                   f"| {v['v_rel_nrmse']:.3f} | {v['f_r_first_harmonic_N']:.2f} |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--amps", type=float, nargs="+", default=[5.0, 10.0])
    ap.add_argument("--duration", type=float, default=0.5, help="simulated time per run [s]")
    ap.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    ap.add_argument("--in-loop", type=float, metavar="SCALE",
                    help="instead: the closed loop on the observer with its normal springs at SCALE k_n_area, "
                         "modes 2-5 at --amps (NRMSE v_rel, the law's u0 error)")
    ap.add_argument("--law", choices=["hysteresis", "lyapunov"], default="hysteresis", help="with --in-loop: the law")
    ap.add_argument("--kind", choices=["observer", "amplitude"], default="observer",
                    help="with --in-loop: the estimator kind (default the paper's observer)")
    ap.add_argument("--fit-scales", action="store_true",
                    help="instead: per --amps, the spring scale whose model's modes 3-5 sit nearest that amplitude's "
                         "passive peaks (fitted_scales)")
    ap.add_argument("--plant-ratios", action="store_true",
                    help="instead: the plant's U_rel / V_meas at mode 5 per --amps, the hysteresis law on the amplitude "
                         "kind at scale 0.1 without a participation, 1 s (plant_ratios: observer.amplitude.PLANT_RATIOS)")
    a = ap.parse_args(argv)
    if not a.duration > 0:
        ap.error(f"--duration {a.duration}: must be > 0 s")
    if a.plant_ratios:
        print("| F [N] | f [Hz] | U_rel [um] | U_rel / V_meas [us] | U_rel / V_tip [us] | u0 error without |\n"
              "| --- | --- | --- | --- | --- | --- |")
        for r in plant_ratios(a.amps):
            print(f"| {r['amp_n']:g} | {r['f_hz']:.2f} | {1e6 * r['U_rel_m']:.4f} | {1e6 * r['rho_meas_s']:.4f} | {1e6 * r['rho_tip_s']:.4f} "
                  f"| {100 * r['u0_error_law']:+.1f} % |", flush=True)
        return 0
    if a.fit_scales:
        missing = [x for x in a.amps if (MODE, x) not in PEAKS_HZ]
        if missing:
            ap.error(f"--fit-scales: no passive peaks at {missing[0]:g} N; amplitudes 5, 10")
        print("| F [N] | scale | modes 3-5 [Hz] | passive peaks [Hz] | rms error | U_rel / V_tip at mode 5 [us] |\n"
              "| --- | --- | --- | --- | --- | --- |")
        for r in fitted_scales(a.amps):
            print(f"| {r['amp_n']:g} | {r['scale']:.4f} | {' / '.join(f'{x:.2f}' for x in r['modes_hz'])} | "
                  f"{' / '.join(f'{x:g}' for x in r['peaks_hz'])} | {100 * r['rms_error']:.3f} % | {r['ratio_us']:.2f} |")
        return 0
    if a.in_loop is not None:
        if not 0 < a.in_loop <= 1:
            ap.error(f"--in-loop {a.in_loop}: a scale in (0, 1]")
        print("| mode | F [N] | model mode [Hz] | NRMSE v_rel | law's u0 error | acc at 0.45 m [m/s^2] |\n"
              "| --- | --- | --- | --- | --- | --- |")
        rows = []
        for mode in (2, 3, 4, 5):
            for amp in a.amps:
                r = in_loop(mode, amp, a.in_loop, a.duration, a.kind, a.law)
                rows.append(r)
                print(f"| {mode} | {amp:g} | {r['model_hz']:.2f} | {r['v_rel_nrmse']:.3f} | "
                      f"{100 * (r['u0_error_law'] or 0.0):+.1f} % | {r['acc045']:.2f} |",
                      flush=True)
                if a.json:
                    a.json.write_text(json.dumps(rows, indent=1))
        return 0
    rows = []
    for amp in a.amps:
        row = one(amp, a.duration)
        rows.append(row)
        print("\n".join(format_rows(row)) + "\n", flush=True)
        if a.json:
            a.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    run_main(main)
