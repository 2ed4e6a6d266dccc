"""Which part of the model form hides an effect, measured on the structure fit itself
(docs/discrepancy.md, "Which part of the model form hides an effect"): a campaign (rig
--model-form PARTS [--refine R], the effect EFFECT hidden at its default strength or --strength S,
seed SEED; --model-form none: the rig's own form) is fitted by the
diagnosis's structure fit (rt.discrepancy.diagnose.structure.fit_structure: calibration alone,
then with the effect) with some of the form's parts told to the model, i.e. the model built in the
form made of those parts (rt.discrepancy.rig.model_form). Printed per told subset: the weighted
FRF residual sum of squares (RSS) of calibration alone and with the effect, the share of the RSS
the effect removes (criterion (b) of the naming asks 25 %), its fitted strength, the calibrated
k_t and modal damping scales, and the share of calibration's RSS in 800-1600 Hz; first, the
effect's own signature: the RSS at the truth's calibration scales with the whole form told,
without and with the effect (with it: the noise's RSS, about the number of residuals n), and the
signature's own RSS, the sum of squares of the difference of the two.

The fits start from the truth's calibration scales (the campaign's scatter; the effect at its
hidden strength), the point the diagnosis would ideally find: a poorer optimum than the
diagnosis's own is possible there (the cost is rough, Method 3). --stage1 fits from stage 1 as the
diagnosis's calibration alone does (about 1 min more per subset) and keeps the better of the two.
About 20-40 s per told subset on one core.

    .venv/bin/python -m benchmarks.model_form_told SEED [--effect micro_slip] [--strength S]
        [--model-form mesh,damping,beams | none] [--refine R] [--told none damping beams damping,beams] [--stage1]
"""
import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.diagnose.campaign import load_campaign
from frictionrt.rt.discrepancy.diagnose.structure import SENSORS, fit_cost, fit_structure, prepare, run_shape, struct_cfg
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.discrepancy.rig import make_campaign, model_form_parts, model_form_refine
from frictionrt.rt.discrepancy.rig.campaign import REFINED_PARTS, model_form, scatter_sets

HIGH_HZ = (800.0, 1600.0)   # the band of modes 7-9, where the model form's remainder lies (docs/discrepancy.md)


def band_share(data, run, band=HIGH_HZ) -> float:
    """Share of the run's weighted RSS (both sensors, all tests) in ``band`` [Hz]."""
    tot = part = 0.0
    for s in SENSORS:
        off = 0
        for d in data:
            f = np.fft.rfftfreq(len(d.F_w), d.dt)[d.sel[s]]
            r = run.r[s][off:off + len(f)]
            off += len(f)
            tot += float(r @ r)
            part += float(r[(f >= band[0]) & (f <= band[1])] @ r[(f >= band[0]) & (f <= band[1])])
    return part / tot


def told_fits(nominal: Config, imp, told: tuple[str, ...], truth: dict, eff, stage1: bool, strength: float,
              refine: int | None = None) -> dict:
    """Calibration alone and with ``eff`` (from ``strength``) on the model in the form made of ``told``
    refined by ``refine`` (module docstring)."""
    refine = refine if set(told) & set(REFINED_PARTS) else None   # the told parts may have nothing to refine
    model = model_form(nominal, told, refine) if told else nominal
    data = prepare(imp, model)
    cals = [fit_structure(model, data, None, start=truth)]
    if stage1:
        cals.append(fit_structure(model, data, None))
    cal = min(cals, key=fit_cost)
    fits = [fit_structure(model, data, eff, start=truth | {eff.name: strength})]
    if stage1:
        fits.append(fit_structure(model, data, eff, calibrated=cal))
    fit = min(fits, key=fit_cost)
    return {"cal": fit_cost(cal), "eff": fit_cost(fit), "strength": fit.theta[eff.name],
            "k_t": cal.theta["k_t"], "damping": cal.theta["modal_damping"], "high": band_share(data, cal.run)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("seed", type=int)
    ap.add_argument("--effect", default="micro_slip")
    ap.add_argument("--strength", type=float, help="hidden strength (default: the effect's default)")
    ap.add_argument("--model-form", default="mesh,damping,beams", metavar="PARTS", help="the truth's form (rig "
                    "--model-form PARTS), or none: the rig's own form")
    ap.add_argument("--refine", metavar="R", help="the truth's discretisation parts refined by R (rig --refine)")
    ap.add_argument("--told", nargs="+", default=["none", "damping", "beams", "damping,beams"],
                    help="subsets of PARTS told to the model (none: the nominal's form)")
    ap.add_argument("--stage1", action="store_true", help="also fit from stage 1, as the diagnosis does")
    args = ap.parse_args()
    form = () if args.model_form == "none" else model_form_parts(args.model_form)
    refine = model_form_refine(args.refine, form) if form else None
    tolds = [() if t == "none" else model_form_parts(t) for t in args.told]
    eff = get(args.effect)
    strength = eff.parameter.default if args.strength is None else args.strength
    nominal = with_sets(Config(), [])
    sc = scatter_sets(np.random.default_rng(args.seed))     # make_campaign's first draw: the truth's scatter
    truth = {k: sc[k] for k in ("E", "k_t", "mu", "modal_damping")} | {"dispersion": 0.0}
    with tempfile.TemporaryDirectory() as d, threadpool_limits(1):
        make_campaign(Path(d) / "c", eff.name, strength, seed=args.seed, other_form=form, refine=refine)
        imp = [t for t in load_campaign(Path(d) / "c") if t.kind == "impulse"]
        full = model_form(nominal, form, refine) if form else nominal
        data = prepare(imp, full)
        runs = [run_shape(struct_cfg(full, truth | {eff.name: a}, eff), data).r for a in (eff.nominal, strength)]
        sig = [sum(float(v @ v) for v in r.values()) for r in runs]
        own = sum(float((runs[0][s] - runs[1][s]) @ (runs[0][s] - runs[1][s])) for s in SENSORS)
        n = sum(len(v) for v in runs[1].values())
        print(f"seed {args.seed}, {eff.name} {strength:g} hidden, truth of form {','.join(form) or 'own'}"
              f"{f' refined x{refine}' if refine else ''}; at the truth's scales, form told: RSS {sig[0]:.0f} without "
              f"the effect, {sig[1]:.0f} with it (n = {n} residuals); the signature's own RSS {own:.0f}")
        print(f"| told | calibration RSS | with {eff.name} | removed | fitted | k_t / damping | RSS in 800-1600 Hz | s |")
        print("| --- |" + " --- |" * 7, flush=True)
        for told in tolds:
            t0 = time.perf_counter()
            r = told_fits(nominal, imp, told, truth, eff, args.stage1, strength, refine)
            print(f"| {','.join(told) or 'none'} | {r['cal']:.0f} | {r['eff']:.0f} | {100 * (1 - r['eff'] / r['cal']):.1f} % | "
                  f"{r['strength']:.3g} | {r['k_t']:.2f} / {r['damping']:.2f} | {100 * r['high']:.0f} % | "
                  f"{time.perf_counter() - t0:.0f} |", flush=True)


if __name__ == "__main__":
    main()
