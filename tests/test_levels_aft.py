"""The harmonic balance by alternating frequency-time (plant.harmonic_frf, method "aft") on the gaping
aluminium lap joint (configs/lap_joint_al.toml, issue 18): against the level tests of the time-stepped
plant with micro_slip hidden, where the pairs at the overlap's ends open and close in every cycle at
10 N, which the describing functions (method "df", normal contact linear) do not hold; and the cheaper
single-start solve that ``diagnose --calibrate-on --harmonic-method aft`` uses (the whole campaign:
docs/discrepancy.md "Amplitude dependence")."""
import numpy as np
import pytest

from plant.harmonic_frf import harmonic_accelerances, harmonic_system
from plant.model import build_plant
from rt.common.config import load
from rt.discrepancy.chain import quiet
from rt.discrepancy.diagnose.frf import prepare, with_sensor_points
from rt.discrepancy.diagnose.levels import contact_note, contact_of, diagnose_levels, gap_db, level_of, nonlinear_H
from rt.discrepancy.rig import true_structure
from rt.discrepancy.rig.levels import make_level_campaign
from rt.log.frf_files import load_frf_folder

CFG = load("configs/lap_joint_al.toml")
LEVELS = (1.0, 10.0)            # [N]: the outer pairs slip (1 N); the overlap's ends gape (10 N)
BAND = (100.0, 150.0)           # [Hz]: mode 2 only (stuck 130 Hz), the mode that softens


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Mode 2's lines (12 a level) of the lap joint's level tests, micro_slip hidden, seed 3."""
    out = tmp_path_factory.mktemp("al_levels") / "c"
    make_level_campaign(out, "micro_slip", seed=3, cfg=CFG, force_levels_n=LEVELS, band_hz=BAND)
    return out


@pytest.mark.xfail(strict=True, reason="issue 31: the aluminium lap joint's end points carry half their area now; the 10 N level's df/aft gaps were measured on full-stiffness end pairs: re-measure (issue 32)")
def test_aft_holds_the_gaping_joint_that_df_does_not(campaign):
    """At the true structure (the campaign's own scatter draw and spread 0.5), the 10 N level: "aft" is
    within 0.3 dB rms of the time-stepped plant on mode 2's lines (measured 0.08 dB), "df" more than
    0.8 dB off (measured 1.15 dB; it keeps the outer pairs closed, which open for up to 45 % of the
    period here), and the df report's note names the level."""
    truth = true_structure(CFG, "micro_slip", None, np.random.default_rng(3))
    tests = load_frf_folder(campaign)
    data = prepare(tests, CFG)
    truth, _ = with_sensor_points(tests, truth)
    i = [level_of(t) for t in tests].index(10.0)
    hb = {"df": [], "aft": []}
    gaps = {m: gap_db(data[i], nonlinear_H(truth, data[i:i + 1], [10.0], method=m, details=hb[m])[0], None) for m in hb}
    assert gaps["aft"] < 0.3 and gaps["df"] > 0.8, gaps
    # df's report says so: the normal gap swings more than the static gap (measured 1.8), aft's pairs open (43 %)
    rows = {m: [{"level_n": 10.0} | contact_of(hb[m][0])] for m in hb}
    assert rows["df"][0]["normal_ratio_max"] > 1.0 and rows["aft"][0]["open_fraction_max"] > 0.3, rows
    assert contact_note(rows["df"], "df", "N").startswith("at 10 N a closed pair's normal gap swings")
    assert contact_note(rows["aft"], "aft", "N") is None


def test_single_start_aft_is_the_multi_start_solution():
    """Without ``branches`` the line's df start is solved only when the continuation fails: the same
    reported solution as with every start (to 1e-9 of |H|), on lines where the overlap's ends gape."""
    hs = harmonic_system(build_plant(quiet(CFG)), {"a": "tip"})
    lines = np.array([120.1, 122.6, 125.2])
    one = harmonic_accelerances(hs, 10.0, lines, branches=False)
    every = harmonic_accelerances(hs, 10.0, lines, branches=True)
    assert one.converged.all() and every.converged.all()
    assert np.max(np.abs(one.H["a"] - every.H["a"]) / np.abs(every.H["a"])) < 1e-9
    # the sweep's first line lands on the closed branch (its start is the df solution), the next ones, continued,
    # on the gaping one: the ends open for a quarter to 40 % of every cycle (measured 0.25-0.41 with the
    # end points at half their tributary area; a third with the earlier full-stiffness end pairs)
    assert np.max(one.open_fraction[0]) == 0.0 and np.min(one.open_fraction[1:, [0, -1]]) > 0.2


def test_an_unknown_method_is_refused(campaign):
    with pytest.raises(ValueError, match="method 'hb': expected one of df, aft"):
        diagnose_levels(campaign, [1.0], CFG, method="hb")

