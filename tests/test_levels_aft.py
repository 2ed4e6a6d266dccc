"""The harmonic balance by alternating frequency-time (plant.harmonic_frf, method "aft") on the gaping
aluminium lap joint (configs/lap_joint_al.toml, issue 18): against the level tests of the time-stepped
plant with micro_slip hidden, where the pairs at the overlap's ends open and close in every cycle at
10 N, which the describing functions (method "df", normal contact linear) do not hold; and the cheaper
single-start solve that ``diagnose --calibrate-on --harmonic-method aft`` uses (the whole campaign:
docs/discrepancy.md "Amplitude dependence")."""
import numpy as np
import pytest

from frictionrt.plant.harmonic_frf import harmonic_accelerances, harmonic_system
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import load
from frictionrt.rt.discrepancy.chain import quiet
from frictionrt.rt.discrepancy.diagnose.frf import prepare, with_sensor_points
from frictionrt.rt.discrepancy.diagnose.levels import contact_note, contact_of, diagnose_levels, gap_db, level_of, nonlinear_H
from frictionrt.rt.discrepancy.rig import true_structure
from frictionrt.rt.discrepancy.rig.levels import make_level_campaign
from frictionrt.rt.log.frf_files import load_frf_folder

CFG = load("configs/lap_joint_al.toml")
LEVELS = (1.0, 10.0)            # [N]: the outer pairs slip (1 N); the overlap's ends gape (10 N)
BAND = (100.0, 150.0)           # [Hz]: mode 2 only (stuck 130 Hz), the mode that softens


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Mode 2's lines (12 a level) of the lap joint's level tests, micro_slip hidden, seed 3."""
    out = tmp_path_factory.mktemp("al_levels") / "c"
    make_level_campaign(out, "micro_slip", seed=3, cfg=CFG, force_levels_n=LEVELS, band_hz=BAND)
    return out


def test_aft_holds_the_gaping_joint_that_df_does_not(campaign):
    """At the true structure (the campaign's own scatter draw and spread 0.5), the 10 N level on mode 2's
    lines. Measured on the converged plant (issue 32: the end points at half their area; 16 lines
    100-150 Hz, both sensors): where the overlap's ends gape (the peak line, 126.3 Hz, open 41 % of the
    period) "aft" is 0.05 / 0.06 dB from the time-stepped plant and "df", which keeps them closed, 0.54 /
    0.53 dB; on the lines where nothing opens both are the same, the campaign's scatter (up to 0.15 dB),
    so over all lines aft 0.066 dB rms, df 0.146 dB (2.2x). On the earlier full-stiffness end pairs df was
    1.15 dB rms off: the half-area ends carry less, so linearising their contact costs less, but only aft
    holds it. The df report's note names the level."""
    truth = true_structure(CFG, "micro_slip", None, np.random.default_rng(3))
    tests = load_frf_folder(campaign)
    data = prepare(tests, CFG)
    truth, _ = with_sensor_points(tests, truth)
    i = [level_of(t) for t in tests].index(10.0)
    hb = {"df": [], "aft": []}
    H = {m: nonlinear_H(truth, data[i:i + 1], [10.0], method=m, details=hb[m])[0] for m in hb}
    gaps = {m: gap_db(data[i], H[m], None) for m in hb}
    # over all lines: aft at the scatter floor (measured 0.066 dB), df above it by the gaping line (2.2x)
    assert gaps["aft"] < 0.1 and gaps["df"] > 1.5 * gaps["aft"], gaps
    # the line where aft's ends are open longest: aft within the scatter of the lines where nothing opens
    # (0.15 dB; measured 0.05-0.06), df beyond it by more than twice that scatter (measured 0.53-0.54)
    r = hb["aft"][0]
    k = int(np.argmax(np.nanmax(r.open_fraction[:, r.closed], axis=1)))
    assert data[i].freq[k] == pytest.approx(126.3, abs=0.1) and np.max(r.open_fraction[k, r.closed]) > 0.3
    err = {m: np.array([20 * np.log10(abs(data[i].H[s][k] / H[m][s][k])) for s in data[i].sel]) for m in hb}
    assert np.max(np.abs(err["aft"])) < 0.2 and np.min(np.abs(err["df"])) > 0.35, err
    # df's report says so: the normal gap swings more than the static gap (measured 3.2), aft's pairs open (41 %)
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

