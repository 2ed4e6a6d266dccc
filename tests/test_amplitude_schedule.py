"""The amplitude-following observer's schedule from the configuration
(observer/amplitude_schedule.py, ``observer.amplitude.schedule_peaks``): the default plant keeps the
measured table; another plant's schedule comes from its own harmonic balance, cached by its plant
key; the harmonic balance's points on the default plant against the measured table (slow)."""
import json

import numpy as np
import pytest

from frictionrt.observer.amplitude import PLANT_PEAKS, frequency_ratios, schedule_peaks
from frictionrt.observer.amplitude_schedule import LEVELS_N, LINES, MODES, cache_file, harmonic_peaks, plant_key
from frictionrt.rt.common.config import load


def test_the_default_plant_keeps_the_measured_table_and_the_key_ignores_what_the_plant_does_not_see():
    cfg = load()
    assert schedule_peaks(cfg) is PLANT_PEAKS
    assert plant_key(load(sets=["tracking.law=lyapunov", "rt.seed=7"])) == plant_key(cfg)
    assert plant_key(load(sets=["tracking.F_min_N=50"])) != plant_key(cfg)


def test_another_plant_reads_its_cached_schedule_without_solving_again(tmp_path, monkeypatch):
    """A plant other than the default's takes harmonic_peaks' points; a second design reads them
    from the cache file (here written by hand: the solve itself is the slow test's)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    cfg = load(sets=["tracking.F_min_N=50", "tracking.F_passive_N=50"])
    path = cache_file(cfg, MODES, LEVELS_N, LINES)
    assert str(path).startswith(str(tmp_path))
    pts = {"2": [[30e-6, 0.99]], "4": [[2e-6, 0.98], [5e-6, 0.97]]}
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({"peaks": pts, "rows": []}))
    peaks = schedule_peaks(cfg)
    assert peaks == {2: ((30e-6, 0.99),), 4: ((2e-6, 0.98), (5e-6, 0.97))}
    r = frequency_ratios(7, (0.0, 2e-6, 5e-6, 1e-3), peaks)
    assert r[3].tolist() == [1.0, 0.98, 0.97, 0.97] and (r[[0, 2, 4, 5, 6]] == 1.0).all()


@pytest.mark.slow
def test_the_harmonic_balance_schedule_of_the_default_plant_against_the_measured_table(tmp_path, monkeypatch):
    """The default plant's points by harmonic balance (aft, 3 harmonics) against ``PLANT_PEAKS``
    interpolated at the same amplitude (docs/studies/observer-amplitude-c.md): within TOLERANCE of
    the ratio, i.e. of the model's relative frequency at that amplitude. About 5 min on 2 loaded cores."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    cfg = load()
    peaks = harmonic_peaks(cfg)
    # measured: mode 2 at 5 and 10 N, mode 3 at 5 N, mode 4 at 10 N; mode 3 at 10 N does not converge
    # on the peak's lines (the gaping branch), mode 4's 5 N peak lies above the lines (at f_sliding)
    assert sorted(peaks) == list(MODES) and sum(len(v) for v in peaks.values()) >= 4
    for mode, pts in peaks.items():
        a0 = np.array([0.0] + [p[0] for p in PLANT_PEAKS[mode]])
        r0 = np.array([1.0] + [p[1] for p in PLANT_PEAKS[mode]])
        for a, r in pts:
            assert 0.95 < r < 1.0
            assert abs(r - np.interp(a, a0, r0)) < TOLERANCE, (mode, a, r, np.interp(a, a0, r0))
    assert cache_file(cfg, MODES, LEVELS_N, LINES).is_file()


# |r_harmonic - r_table| at the same amplitude: measured +0.0001 (mode 3) to +0.0033 (mode 4), the
# balance always on the stiff side; bound 0.004 = that, plus the vertex's error on lines 0.5 % apart
# (a parabola through a peak this sharp: ~0.05 % in f). It is 10-25 % of the softening the table holds
# (r = 0.97-0.99): the computed schedule gets 75-100 % of the measured shift, not all of it.
TOLERANCE = 0.004
