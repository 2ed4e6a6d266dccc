"""Random excitation of the level tests (rt/discrepancy/rig/random_excitation.py, ``rig --frf-files --levels
.. --excitation random``) and a random level in the harmonic balance, the joint's equivalent linearisation
under a Gaussian gap (rt/discrepancy/diagnose/random_level.py), issue 35. Short records here (2 s blocks, 4 averages)."""
from __future__ import annotations

import contextlib
import json
import math
import pickle
from types import SimpleNamespace

import numpy as np
import pytest

from frictionrt.plant.harmonic_frf import harmonic_accelerances, harmonic_system
from frictionrt.plant.model import build_plant
from frictionrt.rt.cli import main
from frictionrt.rt.common.config import load
from frictionrt.rt.discrepancy.diagnose.frf import FRFData
import frictionrt.rt.discrepancy.diagnose.random_level as rl
from frictionrt.rt.discrepancy.diagnose.random_level import RandomLevel
from frictionrt.rt.discrepancy.rig import random_excitation as rx
from frictionrt.rt.discrepancy.rig.frf import sensor_points
from frictionrt.rt.discrepancy.rig.levels import make_level_campaign, sensor_columns, settle_line
from frictionrt.rt.experiments.stepsine import Settle
from frictionrt.rt.log.frf_files import FRFTest, check_meta, load_frf_folder

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


def test_random_level_files(tmp_path, short_records, capsys):
    """Two random levels of a drive voltage: files as the stepped sine's (CSV and UFF), the coherence in
    both (UFF: a function-type-6 data set that pyuff reads), the sidecar's "random", the lines of the band;
    the same seed writes the same files; --calibrate-on refuses method aft for them (the random tests'
    linearisation is df's tangential law)."""
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
    assert main(["diagnose", "--config", LAP, str(out), "--calibrate-on", "1", "--harmonic-method", "aft"]) == 2
    assert "a random test is the joint's equivalent linearisation" in capsys.readouterr().err


def test_a_pairs_rms_is_its_share_of_the_noise_bandwidth_for_one_mode(monkeypatch):
    """One mode, every pair's share flat (pair ratios 1 tangential, 0.5 normal): sigma_j = max|H| sqrt(S_ff B),
    the noise bandwidth B = int |H|^2 df / max |H|^2 = pi zeta f_m (to the band's and the lines' truncation)."""
    f = np.arange(300.0, 450.0, 0.0625)
    fm, zeta = 374.0, 0.004
    H = {"a_frf_meas": fm ** 2 / (fm ** 2 - f ** 2 + 2j * zeta * fm * f)}
    d = FRFData("t", 0.0, f, H, {}, {}, {}, {"measured": np.array([fm])}, points={"a_frf_meas": "tip"})
    t = FRFTest("t", f, H, None, None, {"random": {"rms": 3.0, "band_hz": [50.0, 1200.0]}})
    closed = np.array([True, False, True])
    for name, stub in (("pair_ratios", lambda *a: (closed * 1.0, closed * 0.5)),
                       ("harmonic_system", lambda *a, **k: SimpleNamespace(closed=closed)),
                       ("build_plant", lambda c: None)):
        monkeypatch.setattr(rl, name, stub)
    lv = rl.random_level(t, d, 0.12, load(None))
    sigma = 3.0 / math.sqrt(1150.0) * math.sqrt(math.pi * zeta * fm) / (2.0 * zeta)
    assert float(lv) == 3.0 and lv.band_hz == (50.0, 1200.0) and lv.modes_hz.tolist() == [fm]
    np.testing.assert_allclose(lv.sigma_t_m, [sigma, 0.0, sigma], rtol=0.03)
    np.testing.assert_allclose(lv.sigma_n_m, lv.sigma_t_m / 2.0, rtol=1e-12)


@pytest.mark.parametrize("kf, qf", [([1.0], [1.0]), (np.full(4, 0.25), np.array([0.1, 0.2, 0.3, 0.4]))])
def test_the_gaussian_stiffness_is_the_describing_function_averaged_over_a_rayleigh_envelope(kf, qf):
    """gaussian_stiffness against scipy's adaptive quadrature of k_eq(a) a^3 / (2 sigma^4) e^{-a^2 / (2 sigma^2)}
    (a Jenkins element and a 4-element Iwan one, below, at and beyond the slip onset q / k): within 5e-5 of
    k; sigma 0 and a gap far below the onset stay stuck (k_t)."""
    from scipy.integrate import quad
    from frictionrt.plant.describing import pair_df
    kf, qf = np.asarray(kf, float), np.asarray(qf, float)
    k, q = 2.0e7, 4.0
    for sigma in (0.05e-6, 0.2e-6, 1e-6, 5e-6):
        def part(a, j):
            return pair_df(a, k, q, kf, qf)[0].item().__getattribute__(j) * a ** 3 / (2 * sigma ** 4) * math.exp(
                -a * a / (2 * sigma * sigma))
        ref = complex(*(quad(part, 0.0, 40 * sigma, args=(j,), points=list(qf * q / (kf * k)), limit=400,
                             epsabs=0.0, epsrel=1e-12)[0]
                        for j in ("real", "imag")))
        got = rl.gaussian_stiffness(np.array([sigma]), np.array([k]), np.array([q]), kf, qf)[0]
        assert abs(got - ref) < 5e-5 * k, (sigma, got, ref)
    stuck = rl.gaussian_stiffness(np.array([0.0, 1e-12]), np.array([k, k]), np.array([q, q]), kf, qf)
    np.testing.assert_allclose(stuck, [k, k], rtol=1e-9)


def test_the_marched_law_gives_the_describing_function_under_a_sine():
    """random_level._march, the pairs' law the spectral stiffness simulates: under a cos(theta) after the first
    period its first harmonic over whole periods is plant.describing's k_eq(a) a (a Jenkins element and a
    4-element Iwan one, stuck and slipping), within 2e-3 of k (256 samples a period)."""
    from frictionrt.plant.describing import pair_df
    kf, qf = np.full(4, 0.25), np.array([0.1, 0.2, 0.3, 0.4])
    k, q = 2.0e7, 4.0
    th = 2.0 * math.pi * np.arange(256 * 6) / 256
    for fk, fq in ((np.ones(1), np.ones(1)), (kf, qf)):
        for a in (0.05e-6, 0.3e-6, 2e-6):
            x = a * np.cos(th)[None, :]
            f = np.empty_like(x)
            rl._march(x, (fk * k)[None, :], (fq * q)[None, :], f)
            h1 = 2.0 * np.mean((f[0] * np.exp(-1j * th))[256:]) / a
            assert abs(h1 - pair_df(a, k, q, fk, fq)[0].item()) < 2e-3 * k, (a, h1)


def test_the_linearised_model_is_the_pairs_law_with_its_stiffness_fixed():
    """random_level._linearised (one eigen decomposition for every line) with a complex dk at the closed pairs
    against (D) of plant.harmonic_frf with k_eq - k_t = dk solved line by line: (I + H_tt diag(dk)) g = H_tF,
    the modal response d (Y_b - Y_t dk g) (df_matrices): the sensors' accelerances within 1e-9."""
    from frictionrt.plant.harmonic_frf import df_matrices
    cfg = load(LAP)
    hs = harmonic_system(build_plant(cfg), sensor_points(cfg), F_N1=0.0)
    f = np.array([60.0, 118.0, 124.0, 129.0, 374.0, 730.0, 1100.0])
    ic = np.flatnonzero(hs.closed)
    dk = hs.k_t[ic] * (-0.6 + 0.3j) * np.linspace(1.0, 0.2, len(ic))
    w, XV = rl._linearised(hs, ic, dk, f, hs.X_s)
    D = 1.0 / (2j * math.pi * f[:, None] - hs.lam[None, :])
    Htt, u = df_matrices(hs, ic, D, 1.0)
    g = np.linalg.solve(np.eye(len(ic))[None] + Htt * dk[None, None, :], u[..., None])[..., 0]
    modal = D * (hs.Y_b - (dk * g) @ hs.Y_g[:, 2 * ic + 1].T)
    for k in range(len(hs.names)):
        np.testing.assert_allclose(w @ XV[k], modal @ hs.X_s[k], rtol=1e-9)


def test_a_random_level_is_the_linearised_joint():
    """random_accelerances: at a level far below slip the stuck model's FRF (the harmonic balance at a force far
    below slip); as the level rises mode 2's peak (lap joint, ~129 Hz stuck) falls in frequency and height, the
    joint slips; every line converged; level_accelerances solves a plain level at level x scale."""
    cfg = load(LAP)
    hs = harmonic_system(build_plant(cfg), sensor_points(cfg), F_N1=0.0)
    f = np.arange(115.0, 135.0, 0.0625)
    p = len(hs.closed)
    modes = [129.0, 374.0, 730.0]
    stuck = harmonic_accelerances(hs, 1e-6, f, method="df", branches=False)
    r0 = rl.level_accelerances(hs, RandomLevel(1e-6, np.zeros(p), np.zeros(p), (50.0, 1200.0), modes), 0.37, f)
    for s in r0.H:
        np.testing.assert_allclose(r0.H[s], stuck.H[s], rtol=1e-9)
    assert r0.F_amp == pytest.approx(math.sqrt(2.0) * 1e-6 * 0.37) and r0.converged.all()
    peaks = []
    for rms, sigma in ((1e-6, 0.0), (20.0, 2e-6), (60.0, 6e-6)):   # the end pairs slip from a sine of 2.05 um
        lv = RandomLevel(rms, sigma * hs.closed, 0.1 * sigma * hs.closed, (50.0, 1200.0), modes)
        r = rl.random_accelerances(hs, lv, 1.0, f)
        h = np.abs(r.H["a_tip_meas"])
        peaks.append((f[np.argmax(h)], h.max()))
        assert (r.slip_amp_m.max() > 0.0) == (sigma > 0.0)
    assert peaks[0][0] > peaks[1][0] > peaks[2][0] and peaks[0][1] > peaks[1][1] > peaks[2][1], peaks
    plain = rl.level_accelerances(hs, 5.0, 2.0, f, method="df", branches=False)
    np.testing.assert_array_equal(plain.H["a_tip_meas"], harmonic_accelerances(hs, 10.0, f, method="df",
                                                                              branches=False).H["a_tip_meas"])
    lv = RandomLevel(5.0, [1e-6, 0.0], [2e-7, 0.0], (50.0, 1200.0), [124.0])
    q = pickle.loads(pickle.dumps(lv))
    assert q == 5.0 and q.sigma_t_m.tolist() == [1e-6, 0.0] and q.sigma_n_m.tolist() == [2e-7, 0.0]
    assert q.band_hz == (50.0, 1200.0) and q.modes_hz.tolist() == [124.0] and json.dumps(q) == "5.0"
    assert q.band_of(np.array([10.0, 500.0])).tolist() == [0, 0]


def test_random_and_sine_levels_do_not_mix():
    t = [FRFTest(n, np.array([1.0, 2.0]), {}, None, None, m) for n, m in (("a", {"random": {"rms": 1.0}}), ("b", {}))]
    with pytest.raises(ValueError, match="mix random and sine excitation"):
        rl.random_levels(t, [None, None], [1.0, 2.0], 0.12, load(None))
