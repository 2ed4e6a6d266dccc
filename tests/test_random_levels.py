"""Random excitation of the level tests (rt/discrepancy/rig/random_excitation.py, ``rig --frf-files --levels
.. --excitation random``) and the mapping of a random level to the harmonic balance's sine amplitude
(rt/discrepancy/diagnose/random_level.py), issue 35. Short records here (2 s blocks, 4 averages)."""
from __future__ import annotations

import contextlib
import json
import math
import pickle

import numpy as np
import pytest

from plant.harmonic_frf import harmonic_accelerances, harmonic_system
from plant.model import build_plant
from rt.cli import main
from rt.common.config import load
from rt.discrepancy.diagnose.frf import FRFData
import rt.discrepancy.diagnose.random_level as rl
from rt.discrepancy.diagnose.random_level import RandomLevel, sine_accelerances
from rt.discrepancy.rig import random_excitation as rx
from rt.discrepancy.rig.frf import sensor_points
from rt.discrepancy.rig.levels import make_level_campaign, sensor_columns, settle_line
from rt.experiments.stepsine import Settle
from rt.log.frf_files import FRFTest, check_meta, load_frf_folder

LAP = "configs/lap_joint_al.toml"


@pytest.fixture
def short_records(monkeypatch):
    """2 s blocks (0.5 Hz lines), 4 averages, 1 s lead-in: 6 s a level."""
    monkeypatch.setattr(rx, "BLOCK_S", 2.0)
    monkeypatch.setattr(rx, "AVERAGES", 4)
    monkeypatch.setattr(rx, "LEAD_S", 1.0)


def test_the_force_has_its_rms_and_only_its_band():
    dt = 1.0 / 21000.0
    F = rx.random_force(2.5, 42000, dt, (50.0, 1200.0), np.random.default_rng(1))
    assert math.sqrt(np.mean(F ** 2)) == pytest.approx(2.5, rel=1e-12)
    P = np.abs(np.fft.rfft(F)) ** 2
    f = np.fft.rfftfreq(len(F), dt)
    assert P[(f < 50.0) | (f > 1200.0)].max() < 1e-20 * P.max()
    in_band = P[(f > 60.0) & (f < 1190.0)]
    assert np.mean(in_band[: len(in_band) // 2]) == pytest.approx(np.mean(in_band[len(in_band) // 2:]), rel=0.1)


def test_h1_of_a_stuck_joint_is_the_stepped_sine(short_records):
    """The lap joint without hidden effect at 0.02 N rms (contact stuck): H1 at the lines around mode 3 and
    off it equals the stepped sine's first harmonic at 0.02 N (same plant, same step) within 4 eps + 1 %,
    eps = sqrt(1 - gamma^2) / (gamma sqrt(2 n_d)) the estimator's random error (Hann leakage adds a bias on
    the peak's lines, 0.5 Hz lines against a 1 Hz half-power width)."""
    cfg = load(LAP)
    model = build_plant(cfg)
    cols = sensor_columns(model)
    s = "a_frf_meas"
    r = rx.random_test(model, 0.0, 0.02, (300.0, 450.0), {s: cols[s]}, np.random.default_rng(2))
    assert r.averages == 4 and r.freq_hz[1] - r.freq_hz[0] == pytest.approx(0.5)
    k = int(np.argmax(np.abs(r.H[s])))
    eps = rx.h1_error(r.coherence[s], r.averages)
    for j in (k - 6, k - 2, k, k + 2, k + 6, 10, len(r.freq_hz) - 10):
        h, _, _, ok, _ = settle_line(model, model.initial_state(0.0), -0.5 * math.pi, float(r.freq_hz[j]), 0.02, 0.0,
                                     [cols[s]], Settle(max_s=6.0))
        assert ok
        assert abs(r.H[s][j] / h[0] - 1.0) < 4.0 * eps[j] + 0.01, (r.freq_hz[j], r.H[s][j], h[0], eps[j])


def test_random_level_files(tmp_path, short_records):
    """Two random levels of a drive voltage: files as the stepped sine's (CSV and UFF), the coherence in
    both (UFF: a function-type-6 data set that pyuff reads), the sidecar's "random", the lines of the band;
    the same seed writes the same files."""
    import pyuff
    out = tmp_path / "c"
    make_level_campaign(out, "micro_slip", seed=1, cfg=load(LAP), force_levels_n=(2.0, 1.0), band_hz=(340.0, 410.0),
                        force_scale_N_per_V=0.5, excitation="random")
    tests = load_frf_folder(out)
    assert [t.name for t in tests] == ["level_01", "level_02"]
    for t, v in zip(tests, (1.0, 2.0)):
        assert t.meta["random"] == {"rms": v, "band_hz": [340.0, 410.0], "block_s": 2.0, "averages": 4,
                                    "overlap": 0.5, "window": "hann"}
        assert t.meta["amplitude_n"] is None and t.excitation == "drive_voltage" and "drive_amplitude_v" not in t.meta
        assert t.freq_hz[0] == 340.0 and t.freq_hz[-1] == 410.0 and len(t.freq_hz) == 141
        assert set(t.coherence) == set(t.H) and all(0.0 <= g.min() and g.max() <= 1.0 for g in t.coherence.values())
    assert "a_frf_meas_coh" in (out / "level_01.csv").read_text().splitlines()[0]
    sets = pyuff.UFF(str(out / "level_02.uff")).read_sets()
    coh = [d for d in sets if d["func_type"] == 6]
    assert sorted(d["id1"].strip() for d in coh) == sorted(tests[1].H)
    np.testing.assert_allclose(coh[0]["data"], tests[1].coherence[coh[0]["id1"].strip()])
    again = tmp_path / "again"
    make_level_campaign(again, "micro_slip", seed=1, cfg=load(LAP), force_levels_n=(1.0,), band_hz=(340.0, 410.0),
                        force_scale_N_per_V=0.5, excitation="random")
    assert (again / "level_01.csv").read_bytes() == (out / "level_01.csv").read_bytes()   # the seed's draw


def test_the_mapping_is_the_noise_bandwidth_for_one_mode(monkeypatch):
    """One mode, the joint's share flat (joint_ratio 1): F_b = F_rms sqrt(2 B / (f_hi - f_lo)) with the noise
    bandwidth B = int |H|^2 df / max |H|^2 = pi zeta f_m (to the band's and the lines' truncation)."""
    f = np.arange(300.0, 450.0, 0.0625)
    fm, zeta = 374.0, 0.004
    H = {"a_frf_meas": fm ** 2 / (fm ** 2 - f ** 2 + 2j * zeta * fm * f)}
    d = FRFData("t", 0.0, f, H, {}, {}, {}, {"measured": np.array([fm])}, points={"a_frf_meas": "tip"})
    t = FRFTest("t", f, H, None, None, {"random": {"rms": 3.0, "band_hz": [50.0, 1200.0]}})
    for name, stub in (("joint_ratio", lambda *a: 1.0), ("harmonic_system", lambda *a, **k: None),
                       ("build_plant", lambda c: None)):
        monkeypatch.setattr(rl, name, stub)
    lv = rl.random_level(t, d, 0.12, load(None))
    assert float(lv) == 3.0 and lv.modes_hz.tolist() == [fm]
    B = math.pi * zeta * fm
    assert lv.sine_amps[0] == pytest.approx(3.0 * math.sqrt(2.0 * B / 1150.0), rel=0.03)
    assert lv.amplitudes(np.array([10.0, 374.0, 2000.0])).tolist() == [lv.sine_amps[0]] * 3


def test_random_and_sine_levels_do_not_mix():
    t = [FRFTest(n, np.array([1.0, 2.0]), {}, None, None, m) for n, m in (("a", {"random": {"rms": 1.0}}), ("b", {}))]
    with pytest.raises(ValueError, match="mix random and sine excitation"):
        rl.random_levels(t, [None, None], [1.0, 2.0], 0.12, load(None))


def test_sine_accelerances_solve_each_band_at_its_amplitude():
    """A RandomLevel's lines are solved band by band at their F_b times the force scale, as the harmonic
    balance at that amplitude on the band's lines alone; a plain level at level x scale."""
    cfg = load(LAP)
    hs = harmonic_system(build_plant(cfg), sensor_points(cfg), F_N1=0.0)
    f = np.array([118.0, 122.0, 124.0, 360.0, 372.0, 380.0])
    lv = RandomLevel(5.0, [124.0, 374.0], [0.3, 0.8])
    r = sine_accelerances(hs, lv, 2.0, f, method="df", branches=False)
    a = harmonic_accelerances(hs, 0.6, f[:3], method="df", branches=False)
    b = harmonic_accelerances(hs, 1.6, f[3:], method="df", branches=False)
    for s in r.H:
        np.testing.assert_array_equal(r.H[s], np.concatenate([a.H[s], b.H[s]]))
    np.testing.assert_array_equal(r.slip_amp_m, np.vstack([a.slip_amp_m, b.slip_amp_m]))
    assert r.F_amp == 1.6 and r.freq_hz.tolist() == f.tolist()
    p = sine_accelerances(hs, 5.0, 2.0, f, method="df", branches=False)
    np.testing.assert_array_equal(p.H["a_tip_meas"], harmonic_accelerances(hs, 10.0, f, method="df",
                                                                          branches=False).H["a_tip_meas"])
    q = pickle.loads(pickle.dumps(lv))
    assert q == 5.0 and q.sine_amps.tolist() == [0.3, 0.8] and json.dumps(q) == "5.0"


@pytest.mark.parametrize("argv, words", [
    (["--excitation", "random", "--frf-files"], "add --frf-files --levels"),
    (["--excitation", "random"], "add --frf-files --levels"),
    (["--excitation", "noise", "--frf-files", "--levels", "1,2"], "invalid choice"),
])
def test_rig_excitation_errors(tmp_path, capsys, argv, words):
    with pytest.raises(SystemExit) if words == "invalid choice" else contextlib.nullcontext():
        assert main(["rig", "--effect", "none", "-o", str(tmp_path / "x"), *argv]) == 2
    assert words in capsys.readouterr().err


def test_the_sidecar_random_is_checked():
    meta = {"format": "frictionrt-frf/1", "kind": "frf", "excitation_x_m": 0.085,
            "sensor_positions_m": {"a_tip_meas": 0.4}, "F_N1_N": 0.0, "amplitude_n": None, "description": "",
            "random": {"rms": 2.0, "band_hz": [50.0, 1200.0], "block_s": 16.0, "averages": 10, "overlap": 0.5,
                       "window": "hann"}}
    check_meta(meta)
    for change, words in (({"amplitude_n": 2.0}, "a random test's level is random.rms"),
                          ({"random": {"rms": 2.0}}, "give an object with rms, band_hz"),
                          ({"random": meta["random"] | {"band_hz": [1200.0, 50.0]}}, "0 <= f_lo < f_hi"),
                          ({"random": meta["random"] | {"rms": -1.0}}, "random.rms")):
        with pytest.raises(ValueError, match=words):
            check_meta(meta | change)
