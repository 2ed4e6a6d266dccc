"""The model form at the calibration levels of diagnose --calibrate-on (rt/discrepancy/diagnose/levels_form.py):
when it is tried, which candidates, and the nominal it hands the level models (the named forms held at their
fitted strengths)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from frictionrt.rt.common.config import Config, load, with_sets
from frictionrt.rt.discrepancy.diagnose.frf import FRFData, Fit
from frictionrt.rt.discrepancy.diagnose.levels_form import MIN_MODES, corrected, form_candidates, why_not

BARE_BEAM = Path(__file__).resolve().parents[1] / "configs" / "bare_beam.toml"


def _data(n_modes: int) -> list[FRFData]:
    """One calibration test with ``n_modes`` measured modes (only its modes matter to ``why_not``)."""
    f = np.array([50.0 * (j + 1) for j in range(n_modes)] + [np.nan] * 2)
    return [FRFData("level_01", 100.0, np.array([1.0]), {}, {}, {}, {}, {"measured": f})]


def _linear(E: float) -> Fit:
    return Fit({"E": E, "k_t": 1.0, "modal_damping": 1.0}, {}, [], None, {})


@pytest.mark.parametrize("mode, E, n_modes, tried", [
    ("auto", 0.70, 8, True),          # E pressed (plausible 0.95-1.05): the form is in question
    ("auto", 1.00, 8, False),         # E inside: slip alone explains k_t and damping pressed at several levels
    ("always", 1.00, 8, True),
    ("never", 0.70, 8, False),
    ("auto", 0.70, MIN_MODES - 1, False),   # too few modes to tell a form by its pattern (one mode's band)
])
def test_the_form_is_tried_where_E_is_pressed_on_enough_modes(mode, E, n_modes, tried):
    nominal = with_sets(Config(), [f"diagnosis.model_form={mode}"])
    reason = why_not(nominal, _data(n_modes), _linear(E))
    assert (reason is None) == tried, reason
    if not tried:
        assert {"auto": "E within", "never": "never"}.get(mode, "") in reason or "measured mode" in reason
    # without the linear calibration only the reasons that need none: the fit is not run where they hold
    assert (why_not(nominal, _data(n_modes)) is None) == (mode != "never" and n_modes >= MIN_MODES)


def test_the_named_forms_are_held_at_their_strengths():
    nominal = with_sets(Config(), [])
    cfg = corrected(nominal, {"clamp_compliance": 3e-4, "joint_compliance": 0.003})
    assert all(c.rot_compliance_rad_per_Nm == 3e-4 for c in cfg.plant.clamps)
    assert cfg.plant.interface.k_n_area == pytest.approx(0.003 * nominal.plant.interface.k_n_area, rel=1e-12)
    assert cfg.plant.interface.k_t_area == pytest.approx(0.003 * nominal.plant.interface.k_t_area, rel=1e-12)
    assert corrected(nominal, {}) is nominal


def test_the_form_candidates_are_those_that_apply():
    default = [e.name for e in form_candidates(with_sets(Config(), []))]
    assert default == ["clamp_compliance", "clamp_translation", "joint_compliance", "attached_mass",
                       "attached_spring"]
    bare = [e.name for e in form_candidates(load(BARE_BEAM))]
    assert "joint_compliance" not in bare and "clamp_compliance" in bare    # no interface: no joint to soften


def test_the_report_says_what_the_form_stage_did():
    from frictionrt.rt.discrepancy.diagnose.levels_report import form_line
    assert form_line({}) == "model form: not tried"
    assert form_line({"model_form": {"reason": "diagnosis.model_form = never"}}).endswith("(diagnosis.model_form = never)")
    assert form_line({"model_form": {"reason": None, "named": [], "tried": ["clamp_compliance"]}}) == \
        "model form: nothing named of clamp_compliance"
    named = {"reason": None, "named": ["joint_compliance"], "strengths": {"joint_compliance": 0.003}, "tried": []}
    assert form_line({"model_form": named}) == "model form named and held in both level models: joint_compliance = 0.003"


def test_a_form_of_two_parts_starts_the_second_round():
    """levels_form.two_part_start: the first round's best candidate, when it beats the calibration alone by the
    naming margin of BIC but not by the RSS share and leaves a calibration scale outside its range, starts the
    second round (a compliant clamp and a compliant joint, each alone leaving E or k_t pressed); not where it
    is within the ranges or not better than the calibration by the margin."""
    from frictionrt.rt.discrepancy.diagnose.campaign import NAME_THRESHOLD
    from frictionrt.rt.discrepancy.diagnose.levels_form import two_part_start
    plausible = {"E": (0.95, 1.05), "k_t": (0.128, 12.8), "modal_damping": (0.5, 50.0)}
    base = {"score": 1000.0}
    pressed = {"effect": "joint_compliance", "score": 1000.0 - 2572.0,
               "theta": {"E": 0.717, "k_t": 0.46, "modal_damping": 10.0, "joint_compliance": 0.12}}
    assert two_part_start([pressed], base, plausible) is pressed
    inside = pressed | {"theta": pressed["theta"] | {"E": 0.99}}
    assert two_part_start([inside], base, plausible) is None
    small = pressed | {"score": 1000.0 - NAME_THRESHOLD}
    assert two_part_start([small], base, plausible) is None
    assert two_part_start([], base, plausible) is None
