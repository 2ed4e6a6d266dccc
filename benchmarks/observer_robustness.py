"""Observer robustness table (docs/observer.md section 6): the plant changed, the observer still
designed from the nominal configuration (``frictionrt.rt.loop.build_loop(..., observer_cfg=nominal)``).

    python -m benchmarks.observer_robustness [--duration S] [--jobs 2]

Per case of ``CASES`` (mu -/+30 %, the frequencies -/+2 % through E x 0.98^2 / 1.02^2 on both
beams, the accelerometer noise x 3): mode 3 near its passive resonance
(``frictionrt.plant.modes.passive_resonance_hz`` of the nominal plant, times the case's frequency factor),
5 N, ``--duration`` s (default 1): the hysteresis law's NRMSE of v_rel on the observer (against the
plant's band-limited truth, ``frictionrt.rt.loop.summary``) and the first-harmonic acceleration at 0.45 m
with the passive law and with the Lyapunov law on the observer.
"""
from __future__ import annotations

import argparse
from multiprocessing import Pool

from frictionrt.plant.modes import passive_resonance_hz
from frictionrt.rt.common.config import load
from frictionrt.rt.loop import build_loop, run, summary
from benchmarks.entry import run_main

AMP_N = 5.0


def _beams_E(factor: float) -> tuple[str, ...]:
    """--set of E x factor on both beams."""
    E = load().plant.beams[0].E
    return tuple(f"plant.beams.{b}.E={E * factor:.6g}" for b in ("main", "damper"))


# (name, --set assignments, frequency factor of the excitation)
CASES = (
    ("mu -30 % (0.28)", ("plant.interface.mu=0.28",), 1.0),
    ("mu +30 % (0.52)", ("plant.interface.mu=0.52",), 1.0),
    ("frequencies +2 % (E x 1.0404)", _beams_E(1.0404), 1.02),
    ("frequencies -2 % (E x 0.9604)", _beams_E(0.9604), 0.98),
    ("accelerometer noise x 3", (f"sensors.acc_noise_rms={3 * load().sensors.acc_noise_rms:g}",), 1.0),
)


def one(case) -> tuple:
    """(name, f [Hz], NRMSE v_rel hysteresis, passive acc [m/s^2], Lyapunov acc [m/s^2])."""
    name, sets, ff, duration = case
    nominal = load()
    cfg = load(None, list(sets))
    f = ff * passive_resonance_hz(nominal, 3)
    hyst = summary(run(build_loop(cfg, "hysteresis", "observer", observer_cfg=nominal), f, AMP_N, duration))
    lyap = summary(run(build_loop(cfg, "lyapunov", "observer", observer_cfg=nominal), f, AMP_N, duration))
    pas = summary(run(build_loop(cfg, "passive"), f, AMP_N, duration))
    return name, f, hyst["v_rel_nrmse"], pas["acc045_amplitude"], lyap["acc045_amplitude"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--duration", type=float, default=1.0, help="simulated time per run [s]")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes")
    args = ap.parse_args(argv)
    if not args.duration > 0:
        ap.error(f"--duration {args.duration}: must be > 0 s")
    print("| plant | f [Hz] | NRMSE v_rel (hyst.) | passive [m/s^2] | Lyapunov [m/s^2] |")
    print("| --- | --- | --- | --- | --- |")
    with Pool(args.jobs) as pool:
        for name, f, nrmse, pas, lyap in pool.imap(one, [(*c, args.duration) for c in CASES]):
            print(f"| {name} | {f:.1f} | {nrmse:.3f} | {pas:.2f} | {lyap:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    run_main(main)
