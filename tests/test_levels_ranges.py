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


def test_aft_is_solved_only_where_df_says_a_pair_swings_open(monkeypatch):
    """levels.aft_where_open's choice of lines and its merge, with the harmonic balance stubbed (the physics: the
    slow test below): aft on the lines where a closed pair's df normal ratio reaches AFT_RATIO or df has no
    solution, df's values kept on the others, an open pair's ratio not counted."""
    import dataclasses

    import frictionrt.rt.discrepancy.diagnose.levels as L
    from frictionrt.plant.harmonic_frf import HarmonicFRF
    f = np.array([10.0, 20.0, 30.0, 40.0, 50.0])
    ratio = np.array([[0.1, 9.0], [L.AFT_RATIO, 0.0], [0.2, 0.0], [np.nan, 0.0], [0.49, 5.0]])   # pair 1 open
    calls = []

    def stub(hs, amp, scale, freq, method, **kw):
        calls.append((method, np.asarray(freq).tolist()))
        n = len(freq)
        v = 1.0 if method == "df" else 2.0
        rows = ratio if method == "df" else np.full((n, 2), 7.0)
        return HarmonicFRF(amp * scale, method, np.asarray(freq), {"a": np.full(n, v + 0j)}, np.zeros((n, 2), complex),
                           np.zeros((n, 2), complex), rows, np.zeros((n, 2)), np.full((n, 2), v - 1.0),
                           np.array([True, False]), np.full(2, np.inf), np.ones(n, bool), np.full(n, int(v)),
                           np.zeros(n), np.ones(n, np.int64))

    monkeypatch.setattr(L, "level_accelerances", stub)
    r = L.aft_where_open(None, 1.0, 1.0, f)
    assert calls == [("df", f.tolist()), ("aft", [20.0, 40.0])]
    assert r.method == "aft" and r.H["a"].real.tolist() == [1.0, 2.0, 1.0, 2.0, 1.0]
    assert r.open_fraction[:, 0].tolist() == [0.0, 1.0, 0.0, 1.0, 0.0] and r.iterations.tolist() == [1, 2, 1, 2, 1]
    assert dataclasses.fields(r) == dataclasses.fields(HarmonicFRF)
    calls.clear()
    ratio[:] = 0.0
    assert L.aft_where_open(None, 1.0, 1.0, f).method == "aft" and calls == [("df", f.tolist())]


@pytest.mark.slow   # ~20 s standalone (8-10 s of it compiling plant.aft's Newton, which numba's cache does not keep)
def test_aft_where_the_contact_opens_is_aft():
    """levels.aft_where_open on mode 2's region of the aluminium lap joint at 7.4 N (micro_slip 0.5, seed 3's
    draw; 9 lines 118-138 Hz, where df's normal ratio rises from 0.2 to 3.2 and falls again): on the lines where df's normal ratio reaches AFT_RATIO it is method aft's own
    solution, elsewhere df's, and there aft differs from df by less than 0.01 dB (measured 0.001 dB below a
    ratio of 0.5 on 400 lines)."""
    from frictionrt.plant.harmonic_frf import harmonic_system
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.common.config import load
    from frictionrt.rt.discrepancy.chain import quiet
    from frictionrt.rt.discrepancy.diagnose.levels import AFT_MAX_ITER, AFT_RATIO, aft_where_open
    from frictionrt.rt.discrepancy.diagnose.random_level import level_accelerances
    from frictionrt.rt.discrepancy.rig import true_structure
    from frictionrt.rt.discrepancy.rig.frf import sensor_points
    cfg = load("configs/lap_joint_al.toml")
    true = true_structure(cfg, "micro_slip", None, np.random.default_rng(3))
    hs = harmonic_system(build_plant(quiet(true)), {"a": sensor_points(true)["a_tip_meas"]}, F_N1=0.0)
    f = np.array([118.0, 120.0, 121.5, 122.5, 126.0, 126.5, 131.0, 134.0, 138.0])   # ratio 0.2 .. 3.2 .. 0.2
    mixed = aft_where_open(hs, 20.0, 0.37, f)
    full = level_accelerances(hs, 20.0, 0.37, f, method="aft", branches=False, max_iter=AFT_MAX_ITER)
    df = level_accelerances(hs, 20.0, 0.37, f, method="df", branches=False)
    ratio = np.max(np.where(df.closed[None, :], df.normal_ratio, 0.0), axis=1)
    m = ratio >= AFT_RATIO
    assert 0 < m.sum() < len(f)                      # both kinds of line in the set
    err = np.abs(20.0 * np.log10(np.abs(mixed.H["a"] / full.H["a"])))
    assert np.max(err[~m]) < 0.01 and np.max(err[m]) < 1e-3, (err, ratio)
    assert np.max(np.abs(20.0 * np.log10(np.abs(full.H["a"][m] / df.H["a"][m])))) > 0.1   # aft matters there
