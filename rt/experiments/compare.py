"""The three laws side by side (``frictionrt compare``, the main job of ``make demo``)."""
from __future__ import annotations

import numpy as np

from frictionrt.rt.common.config import LAWS, Config
from frictionrt.rt.loop import Designs, Loop, Run, build_loop, run, summary


def compare(cfg: Config, freq_hz: float, amp_n: float, duration_s: float, estimator: str = "observer",
            progress=None, controller_of=None, designs: Designs | None = None, structure=None) -> dict[str, Run]:
    """One run per law (passive, hysteresis, lyapunov) with the same excitation and seed, the laws
    on ``estimator`` ("observer": the paper's; "oracle": the plant's u_rel, v_rel; the passive law
    ignores it).
    controller_of(loop): the controller of a law's built loop (``run(..., controller=)``, e.g. a
    C export; None: the numba controller), None for all numba. The laws' loops share the plant
    and force-tracking designs (``designs``, None: a fresh ``Designs``; the same bits). structure: an
    imported structure as the plant (``frictionrt.rt.loop.structure.Structure``; None: the beams)."""
    designs = Designs() if designs is None else designs
    runs = {}
    for law in LAWS:
        loop = build_loop(cfg, law, estimator, designs=designs, structure=structure)
        runs[law] = run(loop, freq_hz, amp_n, duration_s, progress=progress,
                        controller=None if controller_of is None else controller_of(loop))
    return runs


def passive_peak_hz(passive: Loop, mode: int, amp_n: float, progress=None, designs: Designs | None = None) -> float:
    """The passive step-sine resonance [Hz] of bending mode ``mode`` (1 = first) of a built passive
    loop at the force amplitude amp_n [N], found as ``reproduce --quick`` finds its peaks: a sweep of QUICK.n_points
    over the mode's band (``mode_bands_hz``, half width ``HALF_WIDTH``, 0.15 for modes outside it),
    then rounds of ``refine_points`` (at most QUICK.refine_rounds), each point settled as QUICK
    settles it. progress(1) after each point. On an imported structure (``passive.structure``) the
    band is that of its m-th mode the laws act on (``stepsine.structure_mode_bands_hz``); designs: the
    study's shared designs (its plant is not built again).

    The linear picture (``frictionrt.plant.modes.passive_resonance_hz``, the adaptive joint sliding) lies a few
    per cent above the friction-damped peak (mode 3, 5 N: 205.2 Hz against 201.6 Hz found here and
    200.55 Hz by the full reproduction), more than the peak is wide: there the laws' stiffer joints
    move their own peaks toward the excitation, and ``compare`` placed there showed the hysteresis
    law 6.5 % above passive where at 201.6 Hz it is 31 % below (1 s runs)."""
    from frictionrt.rt.experiments.reproduce import HALF_WIDTH, QUICK, merge, refine_points
    from frictionrt.rt.experiments.stepsine import mode_bands_hz, resonance_grid, sweep
    lo, hi = mode_bands_hz(passive.cfg, (mode,), designs, passive.structure)[mode]
    r = sweep(passive, resonance_grid([0.5 * (lo + hi)], HALF_WIDTH.get(mode, 0.15), QUICK.n_points), amp_n,
              settle=QUICK.settle, progress=progress)
    for _ in range(QUICK.refine_rounds):
        new = refine_points(r.freq_hz, r.H_abs)
        if not new:
            break
        r = merge([r, sweep(passive, new, amp_n, settle=QUICK.settle, progress=progress)])
    return float(r.freq_hz[int(np.argmax(r.H_abs))])


def table(runs: dict[str, Run]) -> list[dict]:
    """Per law: acceleration amplitude at x = 0.45 m [m/s^2], its change against passive
    ``change_pct`` = 100 (a_law / a_passive - 1) [%] (negative: lower than passive), mean F_N1 [N],
    actuator energy [J]."""
    s = {law: summary(r) for law, r in runs.items()}
    ref = s["passive"]["acc045_amplitude"]
    return [{"law": law, "acc045_amplitude": v["acc045_amplitude"],
             "change_pct": 100.0 * (v["acc045_amplitude"] / ref - 1.0),
             "fn1_mean_n": v["fn1_mean_n"], "actuator_energy_j": v["actuator_energy_j"]} for law, v in s.items()]


def response_at_excitation(r: Run) -> np.ndarray:
    """Displacement at x = 0.45 m [m] band-passed one octave around the excitation frequency
    (zero-phase 2nd-order Butterworth): the start transient of the barely damped mode 1
    (9.8 Hz) and the unresolved-mode content of the raw signals are removed."""
    import scipy.signal as ss
    f, fs = r.freq_hz, 1.0 / r.loop.cfg.dt_s
    sos = ss.butter(2, [0.5 * f, min(2.0 * f, 0.45 * fs)], btype="bandpass", fs=fs, output="sos")
    return ss.sosfiltfilt(sos, r.signal("w_frf"))


def plot(runs: dict[str, Run], path: str | None = None):
    """Response at the excitation frequency and F_N1 over the last 50 ms of each run (PNG)."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=(9, 6))
    (ax_w, ax_f) = fig.subplots(2, 1, sharex=True)
    for law, r in runs.items():
        dt = r.loop.cfg.dt_s
        n = len(r.log)
        m = min(n, int(round(0.05 / dt)))
        t = np.arange(n - m, n) * dt
        ax_w.plot(t, 1e6 * response_at_excitation(r)[-m:], lw=0.9, label=law)
        ax_f.plot(t, r.signal("F_N1")[-m:], lw=0.9, label=law)
    ax_w.set_ylabel("w at x = 0.45 m, band-passed\naround the excitation [um]")
    ax_f.set_ylabel("F_N1 [N]")
    ax_f.set_xlabel("t [s]")
    r0 = next(iter(runs.values()))
    ax_w.set_title(f"{r0.amp_n:g} N at {r0.freq_hz:g} Hz: passive vs hysteresis-optimal vs Lyapunov "
                   f"({r0.loop.estimator})")
    for ax in (ax_w, ax_f):
        ax.grid(True, lw=0.3)
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig
