"""Gain tuning (rt.experiments.tune, rt.cli.tune): the Pareto front and the choice of the best candidate on
known points, grid parsing and refusal, a small real tune of the hysteresis gain, the CLI files."""
import json

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.common.config import ConfigError, load, with_sets
from frictionrt.rt.experiments.tune import candidates, pareto_front, parse_grid, select_best, tune
from frictionrt.rt.loop import Designs, build_loop


def test_pareto_front_and_best_on_known_points():
    # peak changes [dB], negative = lower peak: both objectives minimised
    change = np.array([-1.0, -2.0, -2.0, -3.0, -0.5, np.nan])
    cost = np.array([1.0, 1.0, 2.0, 5.0, 0.1, 0.0])
    # (-2, 2) is dominated by (-2, 1); (-1, 1) by (-2, 1); NaN is never on the front
    assert pareto_front(change, cost).tolist() == [False, True, False, True, True, False]
    assert select_best(change, cost) == 3
    assert select_best(change, cost, max_cost=2.0) == 1          # (-2, 1) beats (-2, 2) on cost
    assert select_best(change, cost, max_cost=0.01) == -1
    # a law that raises the peak (+1 dB) never beats one that lowers it, whatever its power
    assert select_best(np.array([1.0, -0.1]), np.array([0.0, 9.0])) == 1


def test_grid_parsing_and_candidates():
    assert parse_grid(["tracking.K_f=1e7,2e7", "tracking.T1_s=0.01"]) == {"tracking.K_f": (1e7, 2e7),
                                                                         "tracking.T1_s": (0.01,)}
    for bad in ["tracking.K_f", "tracking.K_f=", "tracking.K_f=a,b", "=1,2", "tracking.K_f=nan"]:
        with pytest.raises(ValueError, match="--grid"):
            parse_grid([bad])
    with pytest.raises(ValueError, match="given twice"):
        parse_grid(["tracking.K_f=1", "tracking.K_f=2"])
    base = load()
    cands = candidates(base, {"tracking.K_f": (-1.0, 5e7), "tracking.T1_s": (0.01, 0.04)})
    assert len(cands) == 4
    assert [c.cfg is None for c in cands] == [True, True, False, False]   # K_f must be > 0
    assert "K_f" in cands[0].error
    assert cands[3].cfg.tracking.K_f == 5e7 and cands[3].cfg.tracking.T1_s == 0.04
    assert cands[3].cfg.plant == base.plant                                  # nothing else changed
    with pytest.raises(ConfigError, match="K_ff"):
        candidates(base, {"tracking.K_ff": (1.0,)})                          # a typo is an error


def test_candidates_share_the_plant_and_the_force_tracking_design_built_alone():
    """frictionrt.rt.loop.Designs: a law gain leaves the plant and the force-tracking design shared, a
    tracking.pid_* key gets its own design; every shared loop equals the loop built alone."""
    base = load()
    designs = Designs()
    cfgs = [with_sets(base, s) for s in ([], ["tracking.K_f=1e8"], ["tracking.pid_bandwidth_hz=250"])]
    shared = [build_loop(c, "hysteresis", designs=designs) for c in cfgs]
    assert shared[0].plant is shared[1].plant is shared[2].plant and shared[0].design is shared[1].design
    assert shared[2].design is not shared[0].design
    for c, s in zip(cfgs, shared):
        alone = build_loop(c, "hysteresis")
        assert all(np.array_equal(a, b) for a, b in zip(alone.plant.params, s.plant.params))
        assert alone.design.params == s.design.params and np.array_equal(alone.plant_rest, s.plant_rest)


@pytest.fixture(scope="module")
def small():
    # mode 3 at 5 N, 5 points over +/-15 %: the passive peak there is 34.6 m/s^2 / 5 N = 6.9 (m/s^2)/N
    return tune(load(), "hysteresis", {"tracking.K_f": (1e7, 1e8, -1.0)}, modes=(3,), amps_n=(5.0,), points=5,
                estimator="oracle", jobs=1, progress=False)


def test_a_larger_hysteresis_gain_reduces_the_peak_more_and_costs_more_power(small):
    r = small
    # the grid's highest passive |H| lies within the grid step below the true peak, which is
    # 6.9-7.3 (m/s^2)/N depending on the machine's last bits (the joint rattles at F_min, issue 15)
    assert 5.0 < r.passive_peak[0, 0] <= 8.0
    assert np.allclose(r.peak_change_db[:2], 20 * np.log10(r.peak[:2, 0, 0] / r.passive_peak[0, 0]))
    # K_f 1e8 clamps the joint harder than 1e7: measured -8.3 vs +0.1..+2 dB, power 7.9e-3 vs 3e-4 W
    assert r.peak_change_db[1] < r.peak_change_db[0] - 3.0
    assert r.power_w[1] > 3 * r.power_w[0] > 0
    assert np.isnan(r.peak_change_db[2]) and "K_f" in r.errors[2] and not r.pareto[2]
    assert r.best == 1 and r.best_cfg.tracking.K_f == 1e8
    assert r.best_on_edge() == ["tracking.K_f"]            # 1e8 is the largest value tried


def test_cli_writes_table_plot_and_a_best_toml_that_loads(tmp_path, capsys):
    out = tmp_path / "t"
    code = main(["tune", "--law", "lyapunov", "--grid", "tracking.eps_m_s=0.003,0.03", "--modes", "3",
                 "--points", "5", "--jobs", "1", "--out", str(out), "--json", "--estimator", "oracle"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert sorted(p.name for p in out.iterdir()) == ["best.toml", "pareto.png", "table.csv", "table.md", "tune.json"]
    best = doc["best"]
    assert load(out / "best.toml").tracking.eps_m_s == best["tracking.eps_m_s"]
    # the smaller boundary layer switches harder on the true v_rel: a lower peak, more power (measured
    # -7.9 vs -1.4 dB). On the observer (tune's default) the 3 mm/s layer switches on the estimate's
    # error instead and does worse than passive: measured +2.0 against -4.4 dB (docs/experiments.md)
    rows = {r["tracking.eps_m_s"]: r for r in doc["candidates"]}
    assert "reduction_db" not in rows[0.003]             # the old field, of the opposite sign, is gone
    assert rows[0.003]["peak_change_db"] < rows[0.03]["peak_change_db"] and rows[0.003]["power_w"] > rows[0.03]["power_w"]
    assert len((out / "table.csv").read_text().splitlines()) == 3
    # what the sweeps cost: 3 sweeps (passive and two candidates) of 5 points, in this process
    t = doc["timing"]
    assert t["cores"] == 1 and t["ticks"] == pytest.approx(t["simulated_s"] * 21000, abs=1) and t["tick_s"] > 0
    assert t["ratio"] == pytest.approx(t["wall_s"] / t["tick_s"]) and t["ratio"] > 1.0


@pytest.mark.parametrize("argv, words", [
    (["--law", "hysteresis", "--grid", "tracking.K_ff=1,2"], ["--grid", "K_ff"]),
    (["--law", "hysteresis", "--grid", "tracking.K_f"], ["--grid", "KEY=V1,V2"]),
    (["--law", "hysteresis", "--amp", "-5"], ["amplitudes", "positive"]),
    (["--law", "hysteresis", "--modes", "3,x"], ["--modes"]),
    (["--law", "hysteresis", "--modes", "999"], ["mode 999"]),
    (["--law", "lyapunov", "--jobs", "0"], ["--jobs 0"]),
    (["--law", "lyapunov", "--points", "2"], ["points 2"]),
])
def test_cli_bad_input_exit_2_one_line(argv, words, capsys, tmp_path):
    assert main(["tune", *argv, "--out", str(tmp_path / "t")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert not (tmp_path / "t").exists()
