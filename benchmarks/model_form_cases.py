"""Model-form cases of the FRF-file diagnosis (docs/discrepancy.md "Model-form candidates"): a truth with
a compliant clamp and a compliant joint together, written as FRF files by the virtual rig, diagnosed
with the nominal model; the same with micro-slip at several excitation levels; a voltage-driven shaker.

    python -m benchmarks.model_form_cases [--case b] [--clamp 3e-4] [--joint 0.003] [--clamp-heights 15]
                                          [--levels 40 100 300] [--seed 5] [--json OUT]
    python -m benchmarks.model_form_cases --case a [--seed 0]
    python -m benchmarks.model_form_cases --case c [--force-levels 0.5 1 2 5 10 20] [--spread 0.5]
                                          [--band 50 1200] [--folder DIR] [--seed 5] [--broadband]

Case (a): the default structure, the rig's truth a voltage-driven shaker at the drive point with the
catalogue's parameters (armature 0.1 kg, Bl 10 N/A, R 1.5 ohm: Bl^2 / R = 66.7 N s/m), FRF files per drive
volt (10 N/V, three F_N1 tests), the nominal without a shaker (benchmarks.shaker_two_port's "default",
"catalogue"): the named effect, the armature mass and Bl^2 / R against the truth; done when the shaker is
named and both lie within 20 %.

Case c-truth (``--case c-truth``, the same truth arguments): the truth's modes 3 and 4 by the harmonic
balance over force amplitudes 0.02-300 N, peak line and |H|: whether its joint softens at the levels tested.

Case (c): case (b)'s truth plus micro-slip (plant.interface.iwan_spread ``--spread``, default the effect's
default strength 0.5), stepped-sine level tests of the nonlinear plant at ``--force-levels`` [N]
(rt.discrepancy.rig.levels; ``--folder``: an existing folder of them, else a new temporary one),
``diagnose --calibrate-on`` the two lowest: the model form named at the calibration levels and held
(rt.discrepancy.diagnose.levels_form), the harmonic balance's named effect, and the top level's gap in the
softening band, linear (with the form held, and of the nominal form) against the harmonic balance; done
when micro_slip is named and the top level is predicted at least 3x closer than by the linear model.
``--broadband``: the level tests' folder also holds the low-level FRF over the whole band
(rt.discrepancy.rig.levels.write_broadband), on which the form stage then fits the form.
``--form-given``: the truth's clamp and joint given to the diagnosis as its model form (``diagnose_levels``'
``form``: held as the form stage holds what it names, the form stage not run), the second half of the case alone.

Case (b): the clamp's rotational compliance ``--clamp`` [rad/(N m)] and the joint's stiffness
``--joint`` (x the contact model's k_n_area, k_t_area) in the truth (its scatter and FRF noise of
rt.discrepancy.rig.frf, seed ``--seed``), mode 2 at 100 N shifted by the printed amount against the
nominal. The nominal says how compliant its fixture may be: ``--clamp-heights`` (diagnosis.uncertainty.
clamp_heights: a soft bench vice, 15 beam heights of extra beam, 6.7e-5 x 5 = 3.4e-4 rad/(N m) on the
benchmark's beam; the default 3 would hold the clamp at 6.7e-5). Reported: the truth's mode shifts, what the localisation points at, the named candidates
(first and second round), their fitted strengths against the truth, E against the truth's E (the
scatter draw), the gap before and after, and the CPU time of the diagnosis.
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.diagnose.frf import diagnose_frf
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.discrepancy.rig import scatter_sets
from frictionrt.rt.discrepancy.rig.frf import make_frf_campaign
from benchmarks.entry import run_main


def truth(clamp: float, joint: float, base: Config | None = None) -> Config:
    """The nominal (``base``, default the default configuration) with the clamp's rotational compliance and the
    joint's stiffness ratio of case (b) (no scatter)."""
    cfg = base if base is not None else with_sets(Config(), [])
    return get("joint_compliance").apply(get("clamp_compliance").apply(cfg, clamp), joint)


def shifts(cfg: Config, nominal: Config, F_N1: float = 100.0, n: int = 8) -> list[float]:
    """Relative shifts of the first n stuck frequencies at F_N1 [N] of ``cfg`` against ``nominal``."""
    def f(c):
        m = build_plant(c)
        return stuck_frequencies_hz(m, preloaded_pairs(m, F_N1))[:n]
    return [round(float(x), 4) for x in f(cfg) / f(nominal) - 1.0]


def case_b(clamp: float, joint: float, levels, seed: int, clamp_heights: float = 15.0) -> dict:
    nominal = with_sets(Config(), [f"diagnosis.uncertainty.clamp_heights={clamp_heights!r}"])
    d = Path(tempfile.mkdtemp()) / "case_b"
    base = get("clamp_compliance").apply(nominal, clamp)
    make_frf_campaign(d, "joint_compliance", joint, seed=seed, cfg=base, levels_n=tuple(levels))
    E_true = scatter_sets(np.random.default_rng(seed))["E"]
    t = time.process_time()
    res = diagnose_frf(d, nominal)
    cpu = time.process_time() - t
    fitted = res["fitted_parameters"]
    return {"clamp_true": clamp, "joint_true": joint, "levels": list(levels), "seed": seed,
            "clamp_heights": clamp_heights,
            "truth_shifts_100N": shifts(truth(clamp, joint), nominal),
            "points_at": res["where"]["points_at"], "where_top": res["where"]["parameters"][:4],
            "named": res["named"], "model_form_named": res["model_form"]["named"],
            "ranking": [(r["effect"], r["delta_bic"], r["rss_reduction"], r["fitted"]) for r in res["ranking"]],
            "second_round": res.get("second_round"), "fitted": fitted,
            "E_true": round(E_true, 5), "E_error": round(fitted["E"] / E_true - 1.0, 5),
            "clamp_error": (round(fitted["clamp_compliance"] / clamp - 1.0, 4) if "clamp_compliance" in fitted else None),
            "joint_error": (round(fitted["joint_compliance"] / joint - 1.0, 4) if "joint_compliance" in fitted else None),
            "gap_db": [res["gap_before"]["structure_frf_db"], res["gap_calibrated"]["structure_frf_db"],
                       res["gap_after"]["structure_frf_db"]],
            "plausibility": res["plausibility"]["note"], "cpu_s": round(cpu, 1)}


def case_a(seed: int) -> dict:
    from benchmarks.shaker_two_port import run_case
    t = time.process_time()
    out = run_case("default", "catalogue", seed)
    return out | {"cpu_s": round(time.process_time() - t, 1),
                  "mass_error": round(out["mass_kg"][1] / out["mass_kg"][0] - 1.0, 4),
                  "back_emf_error": round(out["back_emf_Ns_per_m"][1] / out["back_emf_Ns_per_m"][0] - 1.0, 4)}


def case_c(clamp: float, joint: float, force_levels, seed: int, clamp_heights: float = 15.0, spread: float = 0.5,
           folder: str | None = None, band_hz=(50.0, 1200.0), form_given: bool = False,
           broadband: bool = False) -> dict:
    from frictionrt.rt.discrepancy.diagnose.levels import diagnose_levels
    from frictionrt.rt.discrepancy.rig.levels import make_level_campaign
    nominal = with_sets(Config(), [f"diagnosis.uncertainty.clamp_heights={clamp_heights!r}"])
    d = Path(folder) if folder else Path(tempfile.mkdtemp()) / "case_c"
    rig_s = None
    if not d.exists() or not any(d.iterdir()):
        t = time.perf_counter()
        base = get("micro_slip").apply(get("clamp_compliance").apply(nominal, clamp), spread)
        make_level_campaign(d, "joint_compliance", joint, seed=seed, cfg=base, force_levels_n=tuple(force_levels),
                            band_hz=tuple(band_hz), broadband=broadband)
        rig_s = round(time.perf_counter() - t, 1)
    E_true = scatter_sets(np.random.default_rng(seed))["E"]
    levels = sorted(force_levels)
    given = {"clamp_compliance": clamp, "joint_compliance": joint} if form_given else None   # the second half alone
    t = time.process_time()
    res = diagnose_levels(d, levels[:2], nominal, progress=lambda m: print(m, flush=True), form=given)
    cpu = time.process_time() - t
    top = next(p for p in res["prediction"] if p["level_n"] == levels[-1])
    form = res["model_form"]
    ratio = top["gap_linear_db"] / top["gap_nonlinear_db"] if top["gap_nonlinear_db"] > 0 else math.inf
    return {"clamp_true": clamp, "joint_true": joint, "spread_true": spread, "force_levels": levels, "seed": seed,
            "band_hz": list(band_hz), "form_given": form_given, "broadband": broadband,
            "folder": str(d), "rig_wall_s": rig_s,
            "form_on": form.get("on"), "form_named": form["named"], "form_strengths": form["strengths"], "form_reason": form["reason"],
            "form_points_at": form["points_at"], "form_ranking": form["ranking"],
            "form_second_round": form["second_round"],
            "named_effect": res["named_effect"], "ranking": res["ranking"],
            "E_true": round(E_true, 5), "E_linear": res["linear"]["fitted"]["E"],
            "E_nonlinear": res["nonlinear"]["fitted"]["E"], "linear": res["linear"], "nonlinear": res["nonlinear"],
            "linear_nominal_form": form.get("linear_nominal_form"),
            "calibration_gap": res["calibration_gap"], "prediction": res["prediction"],
            "top": top, "top_ratio": round(ratio, 3), "softening_mode": res["softening_mode"],
            "done": res["named_effect"] == "micro_slip" and ratio >= 3.0, "cpu_s": round(cpu, 1)}


def truth_peaks(clamp: float, joint: float, seed: int, spread: float = 0.5, clamp_heights: float = 15.0,
                amplitudes=(0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 10.0, 30.0, 100.0, 300.0), modes=(3, 4)) -> dict:
    """Case (c)'s truth by the harmonic balance (df) at the excitation point, F_N1 held at 100 N: per mode of
    ``modes`` its stuck frequency [Hz] and, per force amplitude [N], the peak line [Hz] and |H| [(m/s^2)/N] on
    81 lines from -15 % to +5 % of it: where the truth's joint softens, before any level test is run."""
    from frictionrt.plant.harmonic_frf import harmonic_system
    from frictionrt.rt.discrepancy.chain import hold_voltage, stack_force
    from frictionrt.rt.discrepancy.diagnose.random_level import level_accelerances
    from frictionrt.rt.discrepancy.rig.campaign import true_structure
    nominal = with_sets(Config(), [f"diagnosis.uncertainty.clamp_heights={clamp_heights!r}"])
    base = get("micro_slip").apply(get("clamp_compliance").apply(nominal, clamp), spread)
    true = true_structure(base, "joint_compliance", joint, np.random.default_rng(seed))
    m = build_plant(true)
    F_N1 = stack_force(true, hold_voltage(true, 100.0))
    f = stuck_frequencies_hz(m, preloaded_pairs(m, F_N1))
    system = harmonic_system(m, {"a": true.plant.excitation_point}, F_N1=F_N1)
    out = {"clamp": clamp, "joint": joint, "spread": spread, "seed": seed, "modes": {}}
    for j in modes:
        lines = np.linspace(0.85 * f[j - 1], 1.05 * f[j - 1], 81)
        rows = []
        for a in amplitudes:
            h = np.abs(level_accelerances(system, a, 1.0, lines, method="df", branches=False).H["a"])
            k = int(np.nanargmax(h))
            rows.append([a, round(float(lines[k]), 1), float(f"{h[k]:.4g}")])
        out["modes"][j] = {"stuck_hz": round(float(f[j - 1]), 2), "amplitude_peak_hz_H": rows}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", choices=("a", "b", "c", "c-truth"), default="b")
    ap.add_argument("--force-levels", type=float, nargs="+", default=[0.5, 1.0, 2.0, 5.0, 10.0, 20.0])
    ap.add_argument("--spread", type=float, default=0.5)
    ap.add_argument("--form-given", action="store_true", help="case c: the nominal holds the truth's clamp and joint")
    ap.add_argument("--broadband", action="store_true", help="case c: a low-level FRF over the whole band beside the "
                    "level tests, the form stage's data")
    ap.add_argument("--band", type=float, nargs=2, default=[50.0, 1200.0], help="case c: the level tests' band [Hz]")
    ap.add_argument("--folder", default=None)
    ap.add_argument("--clamp", type=float, default=3e-4)
    ap.add_argument("--joint", type=float, default=0.003)
    ap.add_argument("--clamp-heights", type=float, default=15.0)
    ap.add_argument("--levels", type=float, nargs="+", default=[40.0, 100.0, 300.0])
    ap.add_argument("--seed", type=int, default=None, help="default 5 (case a: 0)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    seed = a.seed if a.seed is not None else (0 if a.case == "a" else 5)
    if a.case == "a":
        out = case_a(seed)
    elif a.case == "c-truth":
        out = truth_peaks(a.clamp, a.joint, seed, a.spread, a.clamp_heights)
    elif a.case == "c":
        out = case_c(a.clamp, a.joint, a.force_levels, seed, a.clamp_heights, a.spread, a.folder, a.band,
                     a.form_given, a.broadband)
    else:
        out = case_b(a.clamp, a.joint, a.levels, seed, a.clamp_heights)
    text = json.dumps(out, indent=1)
    print(text)
    if a.json:
        Path(a.json).write_text(text + "\n")
    return 0


if __name__ == "__main__":
    run_main(main)
