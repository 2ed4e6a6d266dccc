"""The structure's form at the calibration levels of ``diagnose --calibrate-on`` (docs/discrepancy.md
"Model form at several levels"), before the level models are calibrated.

A joint that slips softens and damps its modes, so at the calibration levels the linear model may press
k_t and the modal damping against their plausible ranges without anything wrong in the model's form; a
uniform E far from its material value is not what slip does (slip moves the joint's modes, not every
mode alike). So the model-form candidates (rt.discrepancy.effects, ``Effect.form``) are tried where the
linear calibration at the lowest calibration level presses E (``FORM_TRIGGER``) against its plausible range
(``diagnosis.model_form`` "auto"; "always": tried; "never": not), on data with at least ``MIN_MODES``
measured modes (a form is told from the pattern of several modes' shifts).

Tried as for FRF files (rt.discrepancy.diagnose.frf), on the broadband tests beside the levels where the
folder has them (sidecar ``broadband``: a low-level FRF over the whole band, all its lines; it holds the modes
below the level tests' band, by which a compliant clamp is told from a uniform E), else on the lowest
calibration level's lines with the level models' weights (its modes' bands, levels.mode_bands): the level
where the joint slips least, so that its linear calibration sees the stuck structure's form rather than slip
(a joint that slips at the calibration levels softens and damps its modes, which a linear fit takes for a
softer joint or an added mass); the localisation
(rt.discrepancy.diagnose.localise), each candidate fitted jointly with E, k_t and the modal damping
(frf.fit), ranked by BIC (rt.discrepancy.diagnose.campaign.rank); a candidate named while a calibration
scale is still pressed (or "always"), each other candidate is fitted with it and with the candidate the
localisation points at (frf.next_candidate). The named candidates, at their fitted strengths, are held in
the nominal (``corrected``) of both level models: the linear model and the harmonic balance are then
calibrated from the corrected form, and the harmonic balance's own candidates leave out those held here.
"""
from __future__ import annotations

from frictionrt.rt.common.config import Config
from frictionrt.rt.discrepancy.diagnose.campaign import NAME_THRESHOLD, bic, rank
from frictionrt.rt.discrepancy.diagnose.frf import CAL_NAMES, FRFData, Fit, fit, fit_label, next_candidate
from frictionrt.rt.discrepancy.diagnose.localise import localise
from frictionrt.rt.discrepancy.diagnose.plausible import outside, ranges
from frictionrt.rt.discrepancy.diagnose.structure import MODES
from frictionrt.rt.discrepancy.diagnose.watch import done_fit
from frictionrt.rt.discrepancy.effects import EFFECTS, Effect, get, model_forms

FORM_TRIGGER = ("E",)   # the calibration scales whose pressed range puts the form in question at several levels
MIN_MODES = 3           # measured modes (of the calibration levels' first test) the form needs


def form_candidates(nominal: Config) -> list[Effect]:
    """The model-form candidates (``Effect.form``: the effects library's and ``model_forms()``) that apply to
    ``nominal`` at their default strength, in the library's order."""
    out = []
    for e in [*EFFECTS.values(), *model_forms()]:
        if not (e.form and e.implemented and e.visible_in_frf_files()):
            continue
        try:
            e.apply(nominal, e.parameter.default)
        except (ValueError, KeyError, StopIteration):
            continue
        out.append(e)
    return out


def corrected(nominal: Config, strengths: dict[str, float]) -> Config:
    """``nominal`` with each model-form candidate of ``strengths`` {name: strength} applied at its strength."""
    cfg = nominal
    for name, s in strengths.items():
        cfg = get(name).apply(cfg, s)
    return cfg


def why_not(nominal: Config, data: list[FRFData], linear: Fit | None = None) -> str | None:
    """Why the form is not tried (module docstring), or None where it is; without the linear calibration
    ``linear`` only the reasons that need none (the mode, too few measured modes)."""
    mode = nominal.diagnosis.model_form
    if mode == "never":
        return "diagnosis.model_form = never"
    n_modes = len(data[0].modes_hz) if data else 0
    if n_modes < MIN_MODES:
        return (f"{n_modes} measured mode(s) at the lowest calibration level: the form is told from the pattern of "
                f"{MIN_MODES} modes' shifts or more")
    if linear is None:
        return None
    pressed = [o for o in outside({k: linear.theta[k] for k in FORM_TRIGGER}, ranges(nominal, list(FORM_TRIGGER)))]
    if mode == "auto" and not pressed:
        return ("the linear calibration at the lowest calibration level keeps " + ", ".join(FORM_TRIGGER) + " within its "
                "plausible range: the model's form is not in question (diagnosis.model_form = always tries it)")
    return None


def two_part_start(ranked: list[dict], base: dict, plausible: dict) -> dict | None:
    """Where the first round names no form (``rank``): its best candidate, if it beats the calibration alone by
    the naming margin of BIC (campaign.NAME_THRESHOLD) but falls short of the RSS share, while the calibration
    scales stay outside their plausible ranges with it: a form of two parts (a compliant clamp with a compliant
    joint), each of which alone leaves the scales pressed (the clamp alone needs k_t below its range, the
    joint alone E); the second round then starts from it, and a pair it names is the form. None otherwise."""
    if not ranked:
        return None
    best = ranked[0]
    if base["score"] - best["score"] <= NAME_THRESHOLD or not outside(best["theta"], plausible):
        return None
    return best


def fit_form(nominal: Config, data: list[FRFData], say, bars: bool, done: dict,
             on: str = "the lowest calibration level") -> dict:
    """The form stage (module docstring) on ``data`` (``on`` names it in the progress messages), the lowest
    calibration level's tests (the modes' bands) or the broadband tests beside the levels (all their lines),
    from the linear calibration there (fitted here, "model form: calibration only" in ``done``): {"tried": names, "named": names, "strengths": {name: fitted strength},
    "ranking": rows, "second_round": rows or None, "points_at", "mode", "reason": why not tried or None,
    "nominal": the corrected nominal (``nominal`` itself where nothing is named)}. Each fit also into ``done``."""
    mode = nominal.diagnosis.model_form
    reason, linear = why_not(nominal, data), None
    if reason is None:       # the linear calibration decides whether E is pressed
        say(f"model form at {on}: calibration only")
        linear = fit(nominal, data, None, bars=bars, label="model form: calibration only")
        done["model form: calibration only"] = done_fit(linear.theta, linear.cfg)
        reason = why_not(nominal, data, linear)
    out = {"tried": [], "named": [], "strengths": {}, "ranking": [], "second_round": None, "points_at": None,
           "mode": mode, "reason": reason, "nominal": nominal}
    if out["reason"] is not None:
        return out
    candidates = form_candidates(nominal)
    say(f"model form at {on}: localisation")
    where = localise(data, nominal, linear.cfg, linear.H, candidates, len(MODES))
    results = [{"effect": None, "theta": linear.theta, "channels": linear.channels,
                "score": bic(linear.channels, len(linear.theta)), "fit": linear}]
    for e in candidates:
        label = f"model form {fit_label(e)}"
        say(f"fit {label}")
        f = fit(nominal, data, e, calibrated=linear, bars=bars, label=label)
        done[label] = done_fit(f.theta, f.cfg)
        results.append({"effect": e.name, "theta": f.theta, "channels": f.channels,
                        "score": bic(f.channels, len(f.theta)), "fit": f, "cfg": f.cfg})
    base, ranked, winner = rank(results)
    out |= {"tried": [e.name for e in candidates], "points_at": where["points_at"],
            "ranking": [{"effect": r["effect"], "delta_bic": round(base["score"] - r["score"], 2),
                         "rss_reduction": round(r["rss_reduction"], 4),
                         "fitted": {k: float(f"{v:.5g}") for k, v in r["theta"].items()}} for r in ranked]}
    plausible = ranges(nominal, list(CAL_NAMES))
    first = winner or two_part_start(ranked, base, plausible)
    if first is None:
        return out
    named, theta = ([winner["effect"]] if winner else []), first["theta"]
    if len(candidates) > 1 and (mode == "always" or outside(first["theta"], plausible)):
        pointed = next((e for e in candidates if e.name == where["points_at"]), None)
        second = next_candidate(nominal, data, get(first["effect"]), first["fit"],
                                [e for e in candidates if e.name != first["effect"]], say, bars, done, pointed)
        out["second_round"] = {"first_named": winner["effect"] if winner else None, "first": first["effect"],
                               "held": second["held"], "named": second["named"], "ranking": second["ranking"]}
        if second["named"]:
            named, theta = [second["held"], second["named"]], second["final"]["theta"]
    if not named:
        return out
    strengths = {n: float(f"{theta[n]:.6g}") for n in named}
    return out | {"named": named, "strengths": strengths, "nominal": corrected(nominal, strengths)}
