"""What the command line computes on an imported structure (``--structure FILE``): modes, the
hammer test and a sine run of the plant, each a function over a built ``SEPlant``."""
from __future__ import annotations

import numba
import numpy as np
import scipy.linalg as sla

from frictionrt.plant.impulse import accelerance_frf, hammer_force, identify
from frictionrt.plant.se_plant import SEPlant, _se_step, build_se_plant, run, stuck_frequencies_hz
from frictionrt.plant.se_coarsen import coarsen_structure
from frictionrt.plant.superelement import DEFAULT_CLUSTERING, load
from frictionrt.rt.common.clock import _now_ns

N_MODES = 8


def load_plant(path: str, cfg, clusters: int = 0, clustering: str = DEFAULT_CLUSTERING) -> SEPlant:
    """Read a superelement file (plant.superelement.load), coarsen its interface to `clusters`
    points if > 0 by `clustering` (plant.se_coarsen.coarsen_structure), and build its plant with cfg."""
    se = coarsen_structure(load(path), clusters, cfg, clustering)
    return build_se_plant(se, cfg)


def _stuck_modes(plant: SEPlant, F_N1: float | None):
    p = plant.params
    d = 1 + p.nt
    x0 = plant.initial_state(F_N1)
    closed = x0[plant.state_slots()["g"]][0::d] < 0.0
    kc = np.zeros(p.G.shape[0])
    kc[0::d] = p.k_n * closed
    for a in range(1, d):
        kc[a::d] = p.k_t * closed
    lam, V = sla.eigh(np.diag(p.omega2) + (p.G.T * kc) @ p.G)
    return np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi), V, closed


def modes_summary(plant: SEPlant, F_N1: float | None = None) -> dict:
    """DOF counts; the lowest frequencies [Hz] of the structure with the contact open, stuck at
    every point, and stuck at the points the bolts close at F_N1 [N] (default: the preload)."""
    se = plant.se
    F = plant.F_N1_initial if F_N1 is None else F_N1
    f_closed, _, closed = _stuck_modes(plant, F)
    f_open = plant.omega[plant.omega > 0] / (2 * np.pi)
    return {"source": se.source, "n_dofs": se.n, "n_points": se.n_points, "friction_dims": se.friction_dims,
            "F_N1_N": float(F), "closed_points": int(closed.sum()),
            "open_hz": [round(float(f), 3) for f in f_open[:N_MODES]],
            "stuck_all_hz": [round(float(f), 3) for f in stuck_frequencies_hz(plant, closed_only=False)[:N_MODES]],
            "stuck_closed_hz": [round(float(f), 3) for f in f_closed[f_closed > 1e-3][:N_MODES]]}


def format_modes(s: dict) -> str:
    lines = [f"imported structure {s['source']}: {s['n_dofs']} DOFs, {s['n_points']} contact points "
             f"({s['friction_dims']}-D friction), {s['closed_points']} closed at F_N1 = {s['F_N1_N']:g} N",
             f"{'mode':>4} {'open [Hz]':>11} {'stuck [Hz]':>11} {'closed stuck [Hz]':>18}"]
    for i in range(max(len(s["open_hz"]), len(s["stuck_all_hz"]))):
        cols = [s[k][i] if i < len(s[k]) else float("nan") for k in ("open_hz", "stuck_all_hz", "stuck_closed_hz")]
        lines.append(f"{i + 1:>4} {cols[0]:>11.2f} {cols[1]:>11.2f} {cols[2]:>18.2f}")
    return "\n".join(lines)


def impulse(plant: SEPlant, cfg, F_N1: float, sensor: str | None = None, n_modes: int = 4) -> dict:
    """The hammer test (plant.impulse's pulse, FRF and fit) on the imported structure: the pulse
    cfg.impulse.peak_N along the first excitation, the accelerance at `sensor` (default: the
    configured FRF point if the superelement names it, else its first sensor). The n_modes modes of
    the closed-stuck linearisation below cfg.impulse.f_max_hz with the largest response
    (|s phi| |b phi|) are identified."""
    se = plant.se
    if not se.excitation.size or not se.sensor_rows.size:
        raise ValueError("the superelement has no excitation or no sensor rows: the hammer test needs both "
                         "(excitation, sensor_rows in docs/superelement.md)")
    names = se.sensor_names
    sensor = sensor or (cfg.plant.frf_point if cfg.plant.frf_point in names else names[0])
    if sensor not in names:
        raise ValueError(f"sensor {sensor!r} is not one of the superelement's sensors {list(names)}")
    imp = cfg.impulse
    dt = cfg.dt_s
    n = int(round(imp.record_s / dt))
    force = hammer_force(n, dt, imp.peak_N, imp.duration_s)
    Y, _ = run(plant, force, F_N1)
    return fit_hammer(plant, cfg, F_N1, force, Y, sensor, n_modes)


def fit_hammer(plant: SEPlant, cfg, F_N1: float, force: np.ndarray, Y: np.ndarray, sensor: str,
               n_modes: int = 4) -> dict:
    """``impulse``'s identification from a run's hammer force [N] and outputs Y (plant.se_plant.run's):
    the accelerance at `sensor` through cfg.impulse's exponential window, the n_modes modes of the
    closed-stuck linearisation at F_N1 [N] with the largest response, fitted (plant.impulse.identify)."""
    imp = cfg.impulse
    dt = cfg.dt_s
    names = plant.se.sensor_names
    acc = Y[:, plant.output_index()[f"a_{sensor}"]]
    tau_w = imp.record_s / 4.0
    freq, H = accelerance_frf(force, acc, dt, tau_w)
    f_lin, V, _ = _stuck_modes(plant, F_N1)
    s_row = plant.params.S[names.index(sensor)]
    part = np.abs(s_row @ V) * np.abs(plant.params.b_exc @ V)
    cand = np.flatnonzero((f_lin > 1.0) & (f_lin < imp.f_max_hz))
    pick = np.sort(cand[np.argsort(part[cand])[::-1][:n_modes]])
    fn, zeta = identify(freq, H, f_lin[pick], tau_w)
    return {"F_N1_N": float(F_N1), "sensor": sensor, "linear_hz": [round(float(f), 3) for f in f_lin[pick]],
            "freq_hz": [round(float(f), 3) for f in fn], "damping_ratio": [float(f"{z:.6g}") for z in zeta],
            "E_fric_J": float(Y[-1, plant.output_index()["E_fric"]]),
            "newton_iter_mean": float(Y[:, plant.output_index()["newton_iter"]].mean())}


@numba.njit(cache=True, nogil=True)
def _timed_run(x0, U, p, wk, Y, step_ns):
    x = x0.copy()
    x_next = np.empty_like(x0)
    ts = np.zeros(2, dtype=np.int64)
    failed = 0
    for k in range(U.shape[0]):
        t0 = _now_ns(ts)
        if _se_step(k, x, U[k], p, x_next, Y[k], wk) < 0:
            failed += 1
        step_ns[k] = _now_ns(ts) - t0
        x, x_next = x_next, x
    return x, failed


def simulate(plant: SEPlant, cfg, freq_hz: float, amp_n: float, duration_s: float, F_N1: float) -> dict:
    """A sine force amp_n sin(2 pi f t) [N] along the first excitation at constant F_N1 [N] (the
    passive joint) for duration_s [s]: the last tenth's peak acceleration at each sensor [m/s^2],
    the friction and damping energies [J], the Newton iterations and the step's wall time [us]."""
    if not plant.se.excitation.size:
        raise ValueError("the superelement has no excitation row: add one (docs/superelement.md)")
    dt = cfg.dt_s
    n = int(round(duration_s / dt))
    t = np.arange(n) * dt
    U = np.column_stack([amp_n * np.sin(2 * np.pi * freq_hz * t), np.full(n, float(F_N1))])
    Y = np.zeros((n, len(plant.output_labels())))
    step_ns = np.zeros(n, dtype=np.int64)
    x0 = plant.initial_state(F_N1)
    _, failed = _timed_run(x0, U, plant.params, plant.new_work(), Y, step_ns)
    if failed:
        raise RuntimeError(f"the contact solve did not converge in {failed} of {n} steps; raise plant.substeps "
                           "or plant.newton_max_iter")
    ix = plant.output_index()
    tail = slice(n - max(1, n // 10), n)
    return {"freq_hz": freq_hz, "amp_n": amp_n, "duration_s": duration_s, "F_N1_N": float(F_N1),
            "peak_accel_m_s2": {s: float(np.abs(Y[tail, ix[f"a_{s}"]]).max()) for s in plant.se.sensor_names},
            "E_fric_J": float(Y[-1, ix["E_fric"]]), "E_damp_J": float(Y[-1, ix["E_damp"]]),
            "W_exc_J": float(Y[-1, ix["W_exc"]]), "newton_iter_mean": float(Y[:, ix["newton_iter"]].mean()),
            "step_median_us": float(np.median(step_ns) / 1e3), "step_p99_us": float(np.percentile(step_ns, 99) / 1e3)}
