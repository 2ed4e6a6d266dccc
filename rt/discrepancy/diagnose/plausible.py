"""Plausible ranges of the diagnosis' calibrated parameters and the fits' penalty outside them
(docs/discrepancy.md "Plausible calibrations").

A fit may move a parameter anywhere the configuration accepts (its hard bounds, rt.discrepancy.chain.
scale_bounds); but a calibration that puts an aluminium beam's E at 0.6 x nominal has not found a material,
it has found that the model's form is wrong (a compliant clamp, the joint's geometry or stiffness). So every
calibrated parameter has a plausible range from what it is, and the user says how uncertain each nominal
value is (``[diagnosis.uncertainty]`` of the configuration, rt.common.config.Uncertainty):

* E: nominal x (1 -+ E_rel), E_rel 0.05. A named metal's modulus scatters by a few % (structural steels
  about 195-215 GPa, wrought aluminium alloys 68-72 GPa, handbook values); the rig's scatter of E is 2 % rms,
  cut at 4 %.
* k_t, the tangential contact stiffness per unit area: ``K_T_STEEL`` 1e12..1e14 N/m^3 for ground steel on
  steel (the order of magnitude the bolted-joint literature gives for flat ground joints at a few MPa, the
  range measured joints show), scaled to the interface's materials by their contact modulus E*
  (1 / E* = sum (1 - nu^2) / E of both sides; a rough contact's stiffness grows with E*): aluminium on
  aluminium x 0.336, 3.4e11..3.4e13 N/m^3.
* mu: ``MU_DRY_METAL`` 0.1..1.5, dry metal on metal (handbook tables: steel on steel 0.5-0.8, clean
  aluminium on aluminium up to 1.05-1.35; oxide films and traces of lubricant bring it towards 0.1).
* modal_damping: ``ZETA_BOLTED`` 5e-4..5e-2 (0.05..5 %), the modal damping ratios of bolted metal structures,
  whose damping the joints dominate.
* clamp compliance [rad/(N m)] (the candidate clamp_compliance): 0 .. clamp_heights x h / (E I) of the
  clamped beam, 3 h by default (A: a real clamp rotates at most like ~3 beam heights h of extra beam; the
  effective root of a clamped beam lies about one height inside the fixture).

``*_factor`` keys of the configuration replace a literature range with nominal / f .. nominal x f.

Penalty: appended to a fit's least-squares residuals, one per parameter with a range,

    p = sqrt(n) d / EDGE_LN,    d = max(0, ln(v / hi), ln(lo / v))    (0 inside the range)

n the fit's data residuals (weighted by their noise, so the sum of their squares at a right model is ~n).
Leaving the range by EDGE_LN (1 %) costs n: as much as the model missing every line by one noise sigma, so
a parameter leaves its range only where the data contradict it, not where the noise pulls (measured on
the aluminium lap joint with a compliant clamp: the calibration alone ends with E at 0.9501 and k_t 0.6 %
beyond their edges, the clamp explains the rest; with E really 0.884 x nominal the data pull E there
regardless, its penalty ~50 n being less than the data would lose). A parameter that the data press
against its range's edge (within ``AT_EDGE_LN`` of it, or beyond) wants to leave it: it is reported
(``outside``) as evidence of a missing effect or a wrong model form; one the data put inside its range
stays off the edge. The penalty is not part of the ranking (BIC on the data residuals, as the priors): a
candidate that explains the data with the parameters inside their ranges beats a calibration that needs
them outside.
"""
from __future__ import annotations

import math

import numpy as np

from frictionrt.rt.common.config import Config
from frictionrt.rt.discrepancy.diagnose.watch import fitted_text

EDGE_LN = 0.01
"""A parameter this far outside its range (on ln) costs the fit n, its data residuals' expected sum of squares."""
AT_EDGE_LN = 1e-3
"""A parameter this close to its range's edge (on ln) or beyond it is pressed there by the data (``outside``)."""
K_T_STEEL = (1e12, 1e14)          # [N/m^3] tangential contact stiffness per area, ground steel on steel
E_STEEL = (210e9, 0.3)            # ([Pa], [-]) the modulus and Poisson's ratio K_T_STEEL refers to
MU_DRY_METAL = (0.1, 1.5)         # [-] dry metal on metal
ZETA_BOLTED = (5e-4, 5e-2)        # [-] modal damping ratios of bolted metal structures
CLAMP = "clamp_compliance"        # the candidate effect whose strength has a range here

MEANING = {
    "E": "a material's modulus is known to a few %: a calibration that needs E at or beyond the edge of that has "
         "found that the model's form is wrong (a compliant clamp, the joint's geometry or stiffness, the beams' "
         "dimensions) or that an effect is missing, not a material",
    "k_t": "outside the contact stiffness per area the literature gives for these materials: the joint's "
           "geometry, its pressure distribution or the way it slips differ from the model's",
    "mu": "outside the friction coefficients of dry metal: the slip the data show comes from something else "
          "(micro-slip, a compliant clamp, the joint's form) or the force level is wrong",
    "modal_damping": "outside the damping of bolted metal structures: damping the model does not place (slip in "
                     "the joint, a damped fixture) or a wrong force scale",
    CLAMP: "a fixture more compliant than a few beam heights of extra beam: the clamp stands for another "
           "missing flexibility (the joint, the beams' geometry)",
}


def _contact_modulus(cfg: Config) -> float:
    """E* [Pa] of the interface's two beams: 1 / E* = sum (1 - nu^2) / E."""
    beams = {b.name: b for b in cfg.plant.beams}
    i = cfg.plant.interface
    return 1.0 / sum((1.0 - beams[n].nu ** 2) / beams[n].E for n in (i.lower, i.upper))


def _around(nominal: float, factor: float, literature: tuple[float, float]) -> tuple[float, float]:
    """(lo, hi) as a scale of ``nominal``: nominal / factor .. x factor, or the literature's [absolute] for factor 0."""
    if factor > 0.0:
        return 1.0 / factor, factor
    return literature[0] / nominal, literature[1] / nominal


def clamp_range(cfg: Config) -> tuple[float, float]:
    """(0, c_max) [rad/(N m)] of the clamp compliance: clamp_heights x h / (E I) of the stiffest clamped beam
    (the candidate sets every clamp's compliance alike)."""
    beams = {b.name: b for b in cfg.plant.beams}
    k = cfg.diagnosis.uncertainty.clamp_heights
    return 0.0, min(k * b.height_m / (b.E * b.width_m * b.height_m ** 3 / 12.0)
                    for b in (beams[c.beam] for c in cfg.plant.clamps))


def ranges(nominal: Config, names) -> dict[str, tuple[float, float]]:
    """{parameter: (lo, hi)} of the ``names`` that have a plausible range around ``nominal`` (module docstring):
    the calibration scales E, k_t, mu, modal_damping (x nominal) and the clamp compliance [rad/(N m)]. Others
    (the force scale, the dispersion, the other candidates' strengths) have none; nor have k_t and mu
    without an interface, or a scale whose nominal is 0."""
    u = nominal.diagnosis.uncertainty
    i = nominal.plant.interface
    out = {}
    for k in names:
        if k == "E":
            out[k] = (1.0 - u.E_rel, 1.0 + u.E_rel)
        elif k == "k_t" and i.enabled:
            scale = _contact_modulus(nominal) / (E_STEEL[0] / (2.0 * (1.0 - E_STEEL[1] ** 2)))
            out[k] = _around(i.k_t_area, u.k_t_factor, (K_T_STEEL[0] * scale, K_T_STEEL[1] * scale))
        elif k == "mu" and i.enabled and i.mu > 0.0:
            out[k] = _around(i.mu, u.mu_factor, MU_DRY_METAL)
        elif k == "modal_damping" and nominal.plant.modal_damping > 0.0:
            out[k] = _around(nominal.plant.modal_damping, u.modal_damping_factor, ZETA_BOLTED)
        elif k == CLAMP and nominal.plant.clamps:
            out[k] = clamp_range(nominal)
    return out


def excess(v: float, lo: float, hi: float) -> float:
    """d = max(0, ln(v / hi), ln(lo / v)): how far v lies outside [lo, hi] on ln (lo 0: no lower end)."""
    d = math.log(v / hi) if v > hi else 0.0
    return max(d, math.log(lo / v)) if 0.0 < v < lo else d


def penalty(names, x, plausible: dict, n: int) -> np.ndarray:
    """The penalty residuals sqrt(n) d / EDGE_LN (module docstring), one per name of ``names`` (0 for a name
    without a range in ``plausible``), of the parameter values x; n the fit's data residuals."""
    w = math.sqrt(n) / EDGE_LN
    return np.array([w * excess(float(v), *plausible[k]) if k in plausible else 0.0 for k, v in zip(names, x)])


def step_box(names, z, log, plausible: dict, lo, hi) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) of one Gauss-Newton step from the optimiser's variables z (ln of the parameter where ``log``)
    within the fit's bounds lo, hi: at most EDGE_LN beyond each name's plausible range, or beyond its value
    where that lies outside already. The step's linear model does not see the penalty's kink at the edge
    (its Jacobian row is 0 inside): a step across it by more would cost the penalty n or more and fail."""
    b_lo, b_hi = np.array(lo, float), np.array(hi, float)
    for j, k in enumerate(names):
        if k in plausible:
            a, b = plausible[k]
            v = math.exp(z[j]) if log[j] else z[j]
            top, bottom = max(b, v) * math.exp(EDGE_LN), min(a, v) * math.exp(-EDGE_LN)
            b_hi[j] = min(hi[j], math.log(top) if log[j] else top)
            if a > 0.0:
                b_lo[j] = max(lo[j], math.log(bottom) if log[j] else bottom)
    return b_lo, b_hi


def outside(theta: dict, plausible: dict) -> list[dict]:
    """{"parameter", "value", "plausible": [lo, hi], "meaning"} of every parameter of ``theta`` that wants to
    leave its range in ``plausible``: within AT_EDGE_LN of an edge or beyond (a lower end 0 is no edge)."""
    def pressed(v, lo, hi):
        return excess(v, lo * math.exp(AT_EDGE_LN), hi * math.exp(-AT_EDGE_LN)) > 0.0
    return [{"parameter": k, "value": float(f"{v:.5g}"), "plausible": [float(f"{b:.5g}") for b in plausible[k]],
             "meaning": MEANING[k]}
            for k, v in theta.items() if k in plausible and pressed(v, *plausible[k])]


def _range_text(o: dict) -> str:
    return f"{o['parameter']} = {o['value']:g} (plausible {o['plausible'][0]:g}..{o['plausible'][1]:g})"


def verdict(plausible: dict, calibration: dict, final: dict, named: str | None, tried: list[str],
            let_go: dict | None = None) -> dict:
    """The report's plausibility section: the ``plausible`` ranges, the parameters of the calibration alone
    (``calibration``: its theta) and of the final fit (``final``) outside them (``outside``), the candidates
    ``tried`` in their place, the ``named`` one, ``let_go`` (the calibration with the ranges let go:
    {"fitted", ...}, or None), and a note that says what it means in words."""
    cal, fin = outside(calibration, plausible), outside(final, plausible)
    which = ", ".join(map(_range_text, cal))
    its = "its" if len(cal) == 1 else "their"
    if not cal and not fin:
        note = "every calibrated parameter lies within its plausible range"
    elif cal and named and not fin:
        note = (f"the calibration alone needs {which}: evidence of a missing effect or a wrong model form; "
                f"{named} takes {its} place with every parameter within its range")
    elif named:
        one = len(fin) == 1
        note = (f"{named} is named, but {', '.join(o['parameter'] for o in fin)} still "
                f"{'lies outside its plausible range' if one else 'lie outside their plausible ranges'}: part of the "
                "model's form is still wrong or a second effect is missing")
    else:
        note = (f"the calibration needs {which}: evidence of a missing effect or a wrong model form; no candidate "
                f"({', '.join(tried) or 'none'}) takes {its} place, so the missing effect is not in the library or "
                "the model's form (geometry, joint, boundary) is wrong: the calibrated model is not a physical one"
                + ("; 'let_go' gives the calibration without the ranges (what the data ask)" if let_go else ""))
    return {"ranges": {k: [float(f"{b:.5g}") for b in v] for k, v in plausible.items()},
            "calibration_outside": cal, "outside": fin, "candidates_tried": list(tried), "let_go": let_go,
            "note": note}


FITS = (("calibration alone", "calibration_outside"), ("final", "outside"), ("linear model", "linear_outside"))
"""The fits of a ``verdict`` whose parameters outside their ranges the report lists (the level diagnosis adds
its linear model's)."""


def summary_lines(p: dict) -> list[str]:
    """The CLI's lines of a ``verdict``: its note, each parameter of the final fit (and of a level diagnosis'
    linear model) outside its range with its meaning, and the fit with the ranges let go."""
    out = [f"plausibility: {p['note']}"]
    out += [f"outside its plausible range ({fit}): {_range_text(o)}: {o['meaning']}"
            for fit, key in FITS[1:] for o in p.get(key, [])]
    if p["let_go"]:
        out.append(f"with the plausible ranges let go: {fitted_text(p['let_go']['fitted'])} (gap "
                   f"{p['let_go']['gap_db']:.3f} dB)")
    return out


def markdown(p: dict) -> list[str]:
    """report.md's section of a ``verdict``: the note, the parameters outside their ranges (of the ``FITS``)
    with their meaning, the fit with the ranges let go, and the ranges."""
    rows = [(fit, o) for fit, key in FITS for o in p.get(key, [])]
    out = ["", "## Plausibility", "", p["note"] + ".", ""]
    if rows:
        out += ["| fit | parameter | value | plausible range | what it means |", "| --- | --- | --- | --- | --- |"]
        out += [f"| {fit} | {o['parameter']} | {o['value']:g} | {o['plausible'][0]:g}..{o['plausible'][1]:g} | "
                f"{o['meaning']} |" for fit, o in rows] + [""]
    if p["let_go"]:
        out += [f"With the plausible ranges let go the calibration is `{p['let_go']['fitted']}` (gap "
                f"{p['let_go']['gap_db']:g} dB): what the data ask, not a physical model.", ""]
    out.append("Plausible ranges (x nominal; clamp compliance in rad/(N m)): "
               + ", ".join(f"{k} {a:g}..{b:g}" for k, (a, b) in p["ranges"].items()) + ".")
    return out
