"""benchmarks.baseline_curve: the one-minimum check on synthetic peaks (wiggle tolerance, a minimum
at either end, two valleys) and a tiny real baseline (two forces, one mode) through
rt.experiments.reproduce.measure, the check and the plot."""
import math

import pytest

from benchmarks.baseline_curve import baseline, main, one_minimum, plot
from benchmarks.entry import run_main
from frictionrt.rt.experiments.reproduce import Plan, measure
from frictionrt.rt.experiments.stepsine import Settle

F = [40.0, 80.0, 120.0, 160.0, 240.0, 320.0, 450.0, 600.0]


def _db(values_db):
    """Peaks [(m/s^2)/N] from dB values."""
    return [10.0 ** (v / 20.0) for v in values_db]


def test_a_valley_holds_and_its_minimum_is_found():
    c = one_minimum(F, _db([20, 17, 14, 12, 13, 15, 18, 21]))
    assert c["holds"] and c["fn1_min_n"] == 160.0 and c["worst_wiggle_db"] == 0.0
    assert c["peak_min"] == pytest.approx(10 ** (12 / 20))


def test_a_minimum_at_either_end_counts():
    assert one_minimum(F, _db([10, 11, 12, 13, 14, 15, 16, 17]))["fn1_min_n"] == 40.0
    c = one_minimum(F, _db([17, 16, 15, 14, 13, 12, 11, 10]))
    assert c["holds"] and c["fn1_min_n"] == 600.0


def test_wiggles_under_the_tolerance_are_ignored_above_it_not():
    wiggly = [20, 17, 17.4, 12, 13, 12.6, 18, 21]        # +0.4 dB on the way down, -0.4 dB on the way up
    c = one_minimum(F, _db(wiggly))
    assert c["holds"] and c["worst_wiggle_db"] == pytest.approx(0.4)
    two_valleys = [20, 14, 17, 12, 13, 15, 18, 21]       # a second valley at 80 N, 3 dB deep
    c = one_minimum(F, _db(two_valleys))
    assert not c["holds"] and c["worst_wiggle_db"] == pytest.approx(3.0) and c["at_n"] == 120.0
    creeping = [20, 17, 16.6, 17.0, 17.4, 12, 18, 21]    # small steps that add up to 0.8 dB: not a wiggle
    c = one_minimum(F, _db(creeping))
    assert not c["holds"] and c["worst_wiggle_db"] == pytest.approx(0.8) and c["at_n"] == 240.0
    assert one_minimum(F, _db(creeping), tol_db=1.0)["holds"]


def test_order_of_the_forces_does_not_matter_and_bad_input_is_refused():
    peaks = _db([20, 17, 14, 12, 13, 15, 18, 21])
    assert one_minimum(F[::-1], peaks[::-1]) == one_minimum(F, peaks)
    with pytest.raises(ValueError):
        one_minimum(F[:3], peaks)
    with pytest.raises(ValueError):
        one_minimum(F[:2], [1.0, math.nan])


def test_a_tiny_real_baseline(cfg, tmp_path):
    plan = Plan(modes=(3,), amps_n=(5.0, 20.0), n_points=3, refine_rounds=0, fn1_n=(600.0,),
                settle=Settle(n_blocks=2, rel_tol=0.05, max_s=0.3))
    curves = baseline(measure(cfg, plan, jobs=1, progress=False), cfg.dt_s)
    assert set(curves) == {3} and set(curves[3]) == {5.0, 20.0}
    for c in curves[3].values():
        assert list(c["peaks_by_fn1"]) == [40.0, 600.0] and all(p > 0 for p in c["peaks_by_fn1"].values())
        assert list(c["settled_by_fn1"]) == list(c["edge_by_fn1"]) == [40.0, 600.0]
        assert c["check"]["holds"]                       # two forces: always one minimum
        assert c["check"]["peak_min"] == pytest.approx(min(c["peaks_by_fn1"].values()))
        assert math.isfinite(c["hysteresis"]["vs_best_db"]) and c["lyapunov"]["vs_best_db"] >= -60
    plot(curves, str(tmp_path / "b.png"))
    assert (tmp_path / "b.png").stat().st_size > 1000


def test_the_harmonic_balance_peak_of_a_stuck_joint_is_the_linear_peak(cfg):
    """benchmarks.baseline_hb.hb_peak at 1 mN, where every closed pair sticks (the aft law then
    adds nothing to the stuck model, plant/harmonic_frf.py): mode 3's peak equals the stuck
    linear accelerance's (plant.linear_frf on 4001 lines) within 0.5 % in |H| and 0.02 % in
    frequency; the tolerance is the parabola through three lines of a peak a few lines wide."""
    import numpy as np

    from benchmarks.baseline_hb import hb_peak
    from frictionrt.plant.harmonic_frf import harmonic_system
    from frictionrt.plant.linear_frf import point_accelerances
    from frictionrt.rt.experiments.stepsine import mode_bands_hz
    from frictionrt.rt.loop import build_loop
    model = build_loop(cfg, "passive").plant
    f_slip, f_stuck = mode_bands_hz(cfg, (3,))[3]
    band = (0.9 * f_slip, 1.01 * f_stuck)
    p = hb_peak(harmonic_system(model, {"a": cfg.plant.frf_point}, 100.0), 1e-3, band)
    f = np.linspace(*band, 4001)
    H = np.abs(point_accelerances(model, {"a": cfg.plant.frf_point}, 100.0, f)["a"])
    k = int(np.argmax(H))
    assert p["converged"] and not p["at_band_edge"]
    assert p["H_abs"] == pytest.approx(H[k], rel=5e-3) and p["peak_hz"] == pytest.approx(f[k], rel=2e-4)


def test_a_bad_set_is_one_line_and_exit_2(capsys):
    with pytest.raises(SystemExit) as end:
        run_main(lambda: main(["--set", "plant.interface.pitch_m=0.007"]))
    assert end.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "plant.interface.pitch_m=0.007" in err[0] and "whole pitches" in err[0], err
