"""What the diagnosis explains and what remains (docs/discrepancy.md "What remains: model form").

A measurement never comes from the model that fits it. The structure channels' weighted residuals r
(ln|H| differences over their noise sigma, rt.discrepancy.diagnose.structure / frf) give, for
the nominal model (0), calibration alone (c) and the final model (f: calibrated, with the named effect
if one is named),

    RSS_x = sum r_x^2 over the structure channels,   n = number of residuals,
    excess = RSS_0 - n                                 (the part of the gap the noise model does not explain:
                                                        E[RSS] = n for residuals of unit variance)
    calibration share = (RSS_0 - RSS_c) / excess,   effect share = (RSS_c - RSS_f) / excess,
    remainder share   = (RSS_f - n) / excess,        the three summing to 1.

The remainder is *within the noise* when RSS_f - n <= ``NOISE_SD`` sqrt(2 n) (RSS of n residuals of
unit variance is chi-square with n degrees of freedom: mean n, standard deviation sqrt(2 n)). Then no
part of the gap remains to explain and the shares are of what was explained, RSS_0 - RSS_f:
calibration share = (RSS_0 - RSS_c) / (RSS_0 - RSS_f), effect share = (RSS_c - RSS_f) / (RSS_0 -
RSS_f), remainder share 0, again summing to 1 (a remainder below n, fitted into the noise, would
otherwise be a negative share beside shares summing to more than 1). The report's percentages are
rounded so that they add up to 100 (largest remainder; ``percent_split``).

The remainder *dominates* when it is more than ``DOMINATES`` of what calibration leaves
(remainder share > DOMINATES (effect share + remainder share)) and the final residuals' rms is above
``NOISE_X`` times the noise model's (1): then the model form differs from the measurement in a way
no calibration scale and no effect of the library describes, and the report says so, with where:
the modes the final model misses by more than ``MODE_TOL`` (relative frequency, identified from the
measurement against the final model's undamped frequency, per test) and the sensors ranked by the rms
of their final residuals.
"""
from __future__ import annotations

import math

import numpy as np

from frictionrt.rt.discrepancy.effects import get

DOMINATES = 0.5        # share of what calibration leaves above which the remainder dominates
NOISE_X = 2.0          # ... and the final weighted residuals' rms above this (noise model: 1)
NOISE_SD = 2.0         # a remainder RSS_f - n within this many standard deviations sqrt(2 n) is noise
MODE_TOL = 0.003       # a mode the final model misses by more than 0.3 % of its frequency is listed
                       # (the identification's scatter on the rig's noise: ~0.05 %; the effects shift 1-3 %)


def _rss(channels: dict) -> tuple[float, int]:
    r = [v for k, v in channels.items() if k.startswith("FRF")]
    if not r:
        return 0.0, 0
    r = np.concatenate(r)
    return float(r @ r), len(r)


def budget(nominal: dict, calibrated: dict, final: dict, modes_after: dict) -> dict:
    """The gap's budget (module docstring) from the structure channels {name: weighted residuals} of
    the nominal, calibrated and final models, and ``modes_after`` {test: rt.discrepancy.diagnose.campaign.modes_table
    of the final model}. Returns {"calibration_share", "effect_share", "remainder_share", "rms_final",
    "remainder_within_noise", "remainder_dominates", "modes_missed": [{"test", "mode", "shift_rel"}],
    "sensors": [{"sensor", "rms"}]}; shares None when the nominal model is already within the noise
    (excess <= 0, or nothing explained and the remainder within the noise)."""
    (r0, n), (rc, _), (rf, _) = _rss(nominal), _rss(calibrated), _rss(final)
    excess = r0 - n
    rms_f = math.sqrt(rf / n) if n else 0.0
    within = bool(n and rf - n <= NOISE_SD * math.sqrt(2.0 * n))
    if excess > 0 and within and r0 > rf:
        shares = {"calibration_share": round((r0 - rc) / (r0 - rf), 4), "effect_share": round((rc - rf) / (r0 - rf), 4),
                  "remainder_share": 0.0}
    elif excess > 0 and not within:
        shares = {"calibration_share": round((r0 - rc) / excess, 4), "effect_share": round((rc - rf) / excess, 4),
                  "remainder_share": round((rf - n) / excess, 4)}
    else:
        shares = {"calibration_share": None, "effect_share": None, "remainder_share": None}
    dominates = bool(excess > 0 and rf - n > DOMINATES * (rc - n) and rms_f > NOISE_X)
    missed = sorted(({"test": t, "mode": int(m), "shift_rel": row["shift_rel"]}
                     for t, rows in modes_after.items() for m, row in rows.items()
                     if row["shift_rel"] is not None and abs(row["shift_rel"]) > MODE_TOL),
                    key=lambda x: -abs(x["shift_rel"]))
    sensors = sorted(({"sensor": k.removeprefix("FRF ").strip(), "rms": round(float(np.sqrt(np.mean(v ** 2))), 3)}
                      for k, v in final.items() if k.startswith("FRF") and len(v)), key=lambda x: -x["rms"])
    return shares | {"rms_final": round(rms_f, 3), "remainder_within_noise": within, "remainder_dominates": dominates,
                     "modes_missed": missed, "sensors": sensors}


def percent_split(shares) -> list[int]:
    """Whole percentages of ``shares`` (each clipped at 0, then taken as parts of their sum) that add
    up to exactly 100: each share's floor, the rest given to the largest fractions (largest remainder)."""
    x = np.maximum(np.asarray(shares, float), 0.0)
    x = 100.0 * x / x.sum() if x.sum() > 0 else np.zeros_like(x)
    out = np.floor(x).astype(int)
    for i in np.argsort(-(x - out), kind="stable")[:100 - int(out.sum()) if x.sum() > 0 else 0]:
        out[i] += 1
    return out.tolist()


def verdict(res: dict) -> str:
    """One paragraph for the report: what calibration, the named effect and the remainder explain,
    and, when the remainder dominates, that the model form differs and where."""
    b = res["gap_budget"]
    if b["remainder_share"] is None:
        return "The nominal model already agrees with the measurement within its noise."
    keys = ("calibration_share", "effect_share", "remainder_share")
    pct = dict(zip(keys, percent_split([b[k] for k in keys])))
    named = res["named_effect"]
    # on FRF files every candidate acts on the FRF channels (the shaker's two-port too)
    on_frf = named is not None and (get(named).channel == "structure" or res.get("input") == "frf_files")
    if named is None:
        effect = "no effect is named"
    elif on_frf:
        effect = f"the named effect ({named}) {pct['effect_share']} %"
    else:
        effect = f"the named effect ({named}) acts on the {get(named).channel} channels, not counted here,"
    if b.get("remainder_within_noise"):
        rest = ("the remainder is within the noise" if named is None or not on_frf else
                "what remains is within the noise")
        text = (f"Of the structure's gap, calibration explains {pct['calibration_share']} %, {effect} and {rest} "
                f"(final weighted residuals' rms {b['rms_final']:.2f}, noise 1).")
    else:
        text = (f"Of the structure's gap beyond the noise, calibration explains {pct['calibration_share']} %, "
                f"{effect} and {pct['remainder_share']} % remains "
                f"(final weighted residuals' rms {b['rms_final']:.2f}, noise 1).")
    if not b["remainder_dominates"]:
        return text
    best = res["ranking"][0] if res["ranking"] else None
    modes = ", ".join(f"mode {m['mode']} in {m['test']} ({100 * m['shift_rel']:+.2f} %)" for m in b["modes_missed"][:6])
    sens = ", ".join(f"{s['sensor']} (rms {s['rms']:.2f})" for s in b["sensors"])
    return (text + " **The remainder dominates: the model form differs from the measurement in ways the library "
            "does not describe** (no calibration scale and no effect of the library explains it; e.g. the joint's "
            "contact discretisation, the mesh, the beams' sections or the damping model)"
            + (f"; the measured modes the final model misses most: {modes}" if modes else "")
            + (f"; residuals by sensor: {sens}" if sens else "")
            + (f". The best candidate, {best['effect']}, would remove {100 * best['rss_reduction']:.0f} % of the "
               f"residual (dBIC {best['delta_bic']:.0f}); it is not named on that evidence." if best and
               not res["named_effect"] else ".")
            + " Refine the model form (docs/discrepancy.md, \"What remains: model form\") before reading a "
              "named effect or a fitted strength.")
