"""The level models' plausible ranges where a model form is held (rt/discrepancy/diagnose/levels.py
``form_ranges``): a compliant joint held at s x the contact's k_t_area leaves the calibration scale k_t's range
where the contact's own stiffness puts it, not at that range / s, which would hold a truth's k_t x 1 out."""
from __future__ import annotations

import numpy as np
import pytest

from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.diagnose.frf import fit, prepare, with_sensor_points
from frictionrt.rt.discrepancy.diagnose.levels import diagnose_levels, form_ranges, mode_bands
from frictionrt.rt.discrepancy.diagnose.levels_form import corrected
from frictionrt.rt.discrepancy.diagnose.plausible import ranges
from frictionrt.rt.discrepancy.rig import scatter_sets
from frictionrt.rt.discrepancy.rig.frf import make_frf_campaign
from frictionrt.rt.log.frf_files import load_frf_folder

JOINT = 0.03        # joint_compliance's default strength: k_t_area 2.3e11 N/m^3, below aluminium's 3.4e11


def test_a_held_joint_leaves_the_contacts_range():
    nominal = with_sets(Config(), [])
    held = corrected(nominal, {"joint_compliance": JOINT})
    lo, hi = form_ranges(nominal)["k_t"]
    assert lo < 1.0 < hi                                  # the contact's own stiffness x 1: plausible
    lo_c, _ = ranges(held, ["k_t"])["k_t"]
    assert lo_c == pytest.approx(lo / JOINT, rel=1e-12)   # the held nominal's own range: / s, x 1 held out
    assert lo_c > 1.0
    assert form_ranges(nominal)["E"] == ranges(held, ["E"])["E"]


@pytest.fixture(scope="module")
def joint_frfs(tmp_path_factory):
    """FRF files (one F_N1 test, 100 N) of the default structure with the joint at JOINT, scatter of seed 5."""
    d = tmp_path_factory.mktemp("joint") / "frf"
    make_frf_campaign(d, "joint_compliance", JOINT, seed=5, levels_n=(100.0,))
    return d


def test_the_linear_level_fit_finds_k_t_with_the_form_held(joint_frfs):
    """The level models' linear fit on the held form, with ``form_ranges``: k_t at the truth's scatter draw
    (within 3 %, the stuck FRFs' 1 % noise), E within 0.5 %. With the held nominal's own ranges the same fit
    ends at k_t x 3.90, E 0.953 and the damping x 8.5, 43.5 noise sigmas against 0.61
    (docs/studies/levels-calibration.md)."""
    nominal = with_sets(Config(), [])
    tests = load_frf_folder(joint_frfs)
    data = [mode_bands(d) for d in prepare(tests, nominal)]
    nominal, _ = with_sensor_points(tests, nominal)
    held = corrected(nominal, {"joint_compliance": JOINT})
    truth = scatter_sets(np.random.default_rng(5))
    right = fit(held, data, None, plausible=form_ranges(nominal))
    assert right.theta["k_t"] == pytest.approx(truth["k_t"], rel=0.03)
    assert right.theta["E"] == pytest.approx(truth["E"], rel=0.005)


def test_a_given_form_must_be_a_model_form(tmp_path):
    with pytest.raises(ValueError, match="micro_slip.*not a model-form candidate"):
        diagnose_levels(tmp_path, [0.5], form={"micro_slip": 0.5})


def test_the_broadband_test_beside_the_levels(tmp_path):
    """rt.discrepancy.rig.levels.write_broadband: the stuck FRF over 4-1600 Hz with the FRF files' noise, read
    back with sidecar broadband true and no level; a sidecar broadband that is not a boolean is refused."""
    from frictionrt.plant.linear_frf import point_accelerances
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.discrepancy.rig.frf import NOISE_REL, sensor_points
    from frictionrt.rt.discrepancy.rig.levels import write_broadband
    from frictionrt.rt.log.frf_files import check_meta
    true = with_sets(Config(), [])
    model = build_plant(true)
    name = write_broadband(tmp_path, true, model, 100.0, np.random.default_rng(0))
    (t,) = load_frf_folder(tmp_path)
    assert name == "broadband.csv" and t.meta["broadband"] is True and t.meta["amplitude_n"] is None
    assert t.freq_hz[0] == 4.0 and t.freq_hz[-1] == 1600.0
    H = point_accelerances(model, sensor_points(true), 100.0, t.freq_hz)
    for s, h in H.items():
        strong = np.abs(h) > 1.0                                 # above the noise floor (2e-3 (m/s^2)/N)
        rel = np.abs(t.H[s][strong] / h[strong] - 1.0)
        assert 0.5 * NOISE_REL < np.sqrt(np.mean(rel ** 2)) < 1.5 * NOISE_REL
    with pytest.raises(ValueError, match="sidecar broadband"):
        check_meta(t.meta | {"broadband": "yes"})
