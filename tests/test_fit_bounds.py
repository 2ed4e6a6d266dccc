"""Fit bounds equal to what the configuration accepts (issue 35 item 2): every calibrated parameter of
every fit of the diagnosis, at each of its bounds, builds a configuration that validates, so no fit can
end (or wander) where the configuration refuses it; the bounds derive from the configuration's own
declarations (rt.common.config.key_range through rt.discrepancy.chain.scale_bounds)."""
import math
from pathlib import Path

import pytest

from frictionrt.rt.common.config import Config, ConfigError, dumps, key_range, load, loads, with_sets
from frictionrt.rt.discrepancy.chain import FIT_MARGIN, scale_bounds, scaled
from frictionrt.rt.discrepancy.diagnose.campaign import ACT_CAL
from frictionrt.rt.discrepancy.diagnose.frf import CAL_NAMES as FRF_NAMES
from frictionrt.rt.discrepancy.diagnose.frf import bound_warnings
from frictionrt.rt.discrepancy.diagnose.levels import fit_bounds
from frictionrt.rt.discrepancy.diagnose.plausible import CLAMP, ranges
from frictionrt.rt.discrepancy.diagnose.structure import CAL_FAR, bounds
from frictionrt.rt.discrepancy.effects import get, implemented

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
EDGE = ["plant.interface.mu=1.5", "plant.modal_damping=0.5"]
"""A nominal near the configuration's ends (mu <= 2, modal_damping <= 1): the fits' own ranges
(mu x 2 or x 10, the damping x 10) reach beyond them."""


TOLD = ["diagnosis.uncertainty.E_rel=0.9", "diagnosis.uncertainty.k_t_factor=1000", "diagnosis.uncertainty.mu_factor=1",
        "diagnosis.uncertainty.modal_damping_factor=100", "diagnosis.uncertainty.clamp_heights=100"]
"""A user who says every nominal is far off (issue 35): plausible ranges wider than the fits' bounds."""


def nominals():
    return ([Config(), with_sets(Config(), EDGE), with_sets(Config(), EDGE + TOLD)]
            + [load(p) for p in sorted(CONFIGS.glob("*.toml"))])


def fits(nominal):
    """{fit: {scale: (lo, hi)}} of every fit's calibration scales as that fit computes them (the
    structure fits: rt.discrepancy.diagnose.structure.bounds, the FRF-file fit the same without mu, the
    level fit ``fit_bounds``, the actuator fit ACT_CAL's)."""
    structure = list(CAL_FAR)
    return {"structure": dict(zip(structure, zip(*bounds(structure, None, nominal)))),
           "frf": dict(zip(FRF_NAMES, zip(*bounds(list(FRF_NAMES), None, nominal)))),
           "levels": {k: b for k, b in fit_bounds(nominal).items() if k in CAL_FAR},
           "actuator": {"c_v": scale_bounds(nominal, "c_v", *ACT_CAL["c_v"])}}


@pytest.mark.parametrize("nominal", nominals(), ids=lambda c: f"mu{c.plant.interface.mu:g}_"
                         f"zeta{c.plant.modal_damping:g}_{c.plant.beams[0].name}")
def test_every_calibration_at_its_bounds_is_a_valid_configuration(nominal):
    """Each scale at its lower and upper bound alone and all of a fit's scales at their bounds together
    (as scaled builds them, also through exp(ln b): the level fit moves ln of the scales) validate."""
    for name, b in fits(nominal).items():
        for corner in (0, 1):
            theta = {k: v[corner] for k, v in b.items()}
            cfg = scaled(nominal, theta)
            assert loads(dumps(cfg)) == cfg          # the calibrated model.toml, [diagnosis.uncertainty] with it
            scaled(nominal, {k: math.exp(math.log(v)) for k, v in theta.items()})
            for k, v in theta.items():
                scaled(nominal, {k: v})


@pytest.mark.parametrize("nominal", nominals(), ids=lambda c: f"Erel{c.diagnosis.uncertainty.E_rel:g}_"
                         f"mu{c.plant.interface.mu:g}_{c.plant.beams[0].name}")
def test_the_plausible_ranges_ends_within_the_bounds_are_valid_configurations(nominal):
    """The penalty pulls a fit towards its plausible ranges (rt.discrepancy.diagnose.plausible), the bounds
    stay the configuration's: each range's ends clipped to the fit's bounds validate, as scales and, for the
    clamp compliance, as the candidate's strength (clipped to its bounds, which the ranges may exceed)."""
    clamp = get(CLAMP)
    for name, b in fits(nominal).items():
        for k, (lo, hi) in ranges(nominal, list(b)).items():
            for v in (lo, hi):
                scaled(nominal, {k: min(max(v, b[k][0]), b[k][1])})
    lo, hi = ranges(nominal, [CLAMP])[CLAMP]
    for v in (lo, hi):
        clamp.apply(nominal, min(max(v, clamp.parameter.lo), clamp.parameter.hi))


def test_the_bounds_are_the_configurations_where_it_is_narrower():
    """mu: the configuration accepts 0..2, so at the nominal 0.4 the level fit's x 10 becomes x 5 and the
    structure fit's x 2 stays; at mu 1.5 both end at 2 / 1.5 (FIT_MARGIN inside); the modal damping 0.5
    may rise x 2 (<= 1), not x 10; one step beyond the bound is refused, naming the key."""
    lo, hi = fit_bounds(Config())["mu"]
    assert (lo, hi) == (0.1, pytest.approx(2.0 / 0.4 * (1 - FIT_MARGIN), rel=1e-15))
    assert bounds(["mu"], None, Config())[1][0] == 2.0
    edge = with_sets(Config(), EDGE)
    assert fit_bounds(edge)["mu"][1] == pytest.approx(2.0 / 1.5, rel=1e-8)
    assert bounds(["mu"], None, edge)[1][0] == pytest.approx(2.0 / 1.5, rel=1e-8)
    assert fit_bounds(edge)["modal_damping"] == (0.1, pytest.approx(2.0, rel=1e-8))
    with pytest.raises(ConfigError, match=r"plant.interface.mu = 2.0000\d+ is not allowed: must be 0 <= value <= 2"):
        scaled(edge, {"mu": 2.0 / 1.5 * (1 + 1e-6)})
    assert key_range(Config(), "plant.beams.main.E") == (0.0, None, False)
    with pytest.raises(ConfigError, match="unknown key"):
        key_range(Config(), "plant.interface.nope")


def test_a_fit_on_the_configurations_bound_is_warned():
    """bound_warnings uses the fit's bounds: the level fit's mu on 2 / 1.5 at the edge nominal."""
    edge = with_sets(Config(), EDGE)
    hi = fit_bounds(edge)["mu"][1]
    w = bound_warnings({"mu": hi}, None, False, edge, fit_bounds(edge))
    assert [(x["parameter"], x["bound"]) for x in w] == [("mu", hi)]


@pytest.mark.parametrize("effect", [e.name for e in implemented()])
def test_every_candidates_strength_at_its_bounds_is_a_valid_configuration(effect):
    """The candidates' strengths (the structure, FRF-file, level, actuator and step-sine fits fit them
    within Parameter.lo..hi) applied at both bounds validate, on every configuration the effect applies to."""
    e = get(effect)
    applied = 0
    for nominal in nominals():
        try:
            e.apply(nominal, e.parameter.default)
        except ValueError:          # no place for it (as frf._candidates: no adaptive screw, no frf point)
            continue
        for s in (e.parameter.lo, e.parameter.hi):
            assert isinstance(e.apply(nominal, s), Config)
        applied += 1
    assert applied >= 2


OPTIMISERS = ("least_squares", "lsq_linear", "minimize_scalar", "minimize", "curve_fit")
CHECKED = {("campaign", "fit_actuator"): "actuator", ("levels", "fit_nonlinear"): "levels",
           ("structure", "fit_frequencies"): "structure, frf", ("gauss_newton", "gauss_newton_broyden"): "structure, frf",
           ("stepsine", "fit_shaker"): "the candidates' strengths"}
"""Every function of the diagnosis that calls a bounded optimiser, and the fits of ``fits`` (or the candidates'
test) that check its bounds."""


def test_every_optimiser_of_the_diagnosis_is_a_fit_checked_here():
    """A new fit (a call of scipy's optimisers anywhere in rt/discrepancy) must join ``fits`` above and CHECKED:
    the bounds tests cover every fit only if they know them all."""
    import ast
    root = Path(__file__).resolve().parents[1] / "rt" / "discrepancy"
    found = set()
    for f in root.rglob("*.py"):
        for fn in ast.walk(ast.parse(f.read_text())):
            if isinstance(fn, ast.FunctionDef) and any(
                    isinstance(c, ast.Call) and getattr(c.func, "id", getattr(c.func, "attr", None)) in OPTIMISERS
                    for c in ast.walk(fn)):
                found.add((f.stem, fn.name))
    assert found == set(CHECKED), f"fits not checked by these tests: {found - set(CHECKED)}"


def test_the_shaker_candidates_bounds_on_frfs_per_volt_are_valid_configurations():
    """The FRF-file fit of the voltage-driven shaker (rt.discrepancy.diagnose.frf.fit_shaker_frf) moves the
    armature mass and c_e = Bl^2 / R within SHAKER_BOUNDS: every corner, on every nominal, validates as the
    model.toml it writes (Bl = sqrt(c_e R) > 0 also at c_e = 0)."""
    from frictionrt.rt.discrepancy.diagnose.frf import BACK_EMF, SHAKER, SHAKER_BOUNDS, shaker_config
    for nominal in nominals():
        for m in SHAKER_BOUNDS[SHAKER]:
            for c in SHAKER_BOUNDS[BACK_EMF]:
                cfg = shaker_config(nominal, m, c)
                cfg = with_sets(cfg, [f"shaker.force_constant_N_per_A={cfg.shaker.force_constant_N_per_A!r}"])
                assert loads(dumps(cfg)) == cfg and cfg.shaker.amplifier == "voltage"
