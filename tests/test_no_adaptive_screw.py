"""Structures as labs have them (issue 18): ordinary bolts only, or no interface at all.

configs/bare_beam.toml (the benchmark's main beam alone) against Euler-Bernoulli;
configs/lap_joint_al.toml (two aluminium beams, one lap joint with two ordinary bolts) against
the exact frequencies of the stepped beam between its slip and bonded limits; the commands that
run without an adaptive screw, and the one-line refusal of those that need it.
"""
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from frictionrt.plant.structure import build_structure
from frictionrt.rt.cli.app import main
from frictionrt.rt.common.config import ConfigError, adaptive_screw, dumps, load, loads

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
BARE = CONFIGS / "bare_beam.toml"
LAP_AL = CONFIGS / "lap_joint_al.toml"
BETA_L = (1.87510, 4.69409, 7.85476, 10.99554)   # clamped-free Euler-Bernoulli beam, beta_n L


def _json(capsys, argv) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_zero_adaptive_screws_accepted_with_ordinary_bolts():
    cfg = load(LAP_AL)
    assert adaptive_screw(cfg) is None and len(cfg.plant.screws) == 2
    # the preload of a 1/4-20 bolt at 5 N m with nut factor 0.2: F = T / (K d)
    for s in cfg.plant.screws:
        assert s.F_N == pytest.approx(5.0 / (0.2 * 0.00635), abs=0.01)
    st = build_structure(cfg)
    assert st.adaptive == -1 and st.F_N1_initial == 0.0
    assert not st.b_N1.any() and not st.u_rel_row.any()        # F_N1 acts on nothing, u_rel reads 0
    np.testing.assert_array_equal(st.bolt_F, [3937.0, 3937.0])
    # the benchmark with its adaptive screw made an ordinary bolt is valid too
    assert adaptive_screw(load(sets=["plant.screws.adaptive.adaptive=false"])) is None


def test_two_adaptive_screws_refused_naming_them():
    with pytest.raises(ConfigError, match=r"at most one screw may be adaptive .* found 2 \(normal, adaptive\)"):
        load(sets=["plant.screws.normal.adaptive=true"])


def test_screws_without_interface_refused_and_the_bare_beam_round_trips():
    with pytest.raises(ConfigError, match=r"2 screw\(s\) \(normal, adaptive\) but plant.interface.enabled = false"):
        load(sets=["plant.interface.enabled=false"])
    cfg = load(BARE)
    assert cfg.plant.screws == () and not cfg.plant.interface.enabled
    # `screws = []` is written out: omitted, loading the TOML would bring the default screws back
    assert "screws = []" in dumps(cfg) and loads(dumps(cfg)) == cfg


def test_bare_beam_modes_are_euler_bernoulli(capsys):
    s = _json(capsys, ["--config", str(BARE), "modes", "--json"])
    b = load(BARE).plant.beams[0]
    EI, m = b.E * b.width_m * b.height_m**3 / 12, b.rho * b.width_m * b.height_m
    f = np.array(BETA_L) ** 2 / (2 * np.pi * b.length_m**2) * np.sqrt(EI / m)
    # beta_n L to 6 digits (f ~ (beta L)^2: <= 5.3e-6), the JSON's 4 decimals (<= 4.5e-6 at 11 Hz)
    # and the 10 mm Hermite mesh (measured <= 1.8e-6 up to mode 4): 2e-5; Craig-Bampton adds 7e-6
    np.testing.assert_allclose(s["bare_cantilever_hz"][:4], f, rtol=2e-5)
    np.testing.assert_allclose(s["full_stuck_hz"][:4], f, rtol=2e-5)
    np.testing.assert_allclose(s["reduced_stuck_hz"][:4], f, rtol=5e-5)
    assert s["n_pairs"] == 0 and s["sliding_joint_hz"] is None and s["k_T_adaptive_N_per_m"] is None


def _field(EI: float, m: float, l: float, w: float) -> np.ndarray:
    """Transfer matrix of an Euler-Bernoulli segment (EI [N m^2], m [kg/m], length l [m]) at
    omega w [rad/s] on the state (w, w', EI w'', EI w'''), from the Krylov-Duncan functions."""
    b = (m * w * w / EI) ** 0.25
    x = b * l
    S, T = (np.cosh(x) + np.cos(x)) / 2, (np.sinh(x) + np.sin(x)) / 2
    U, V = (np.cosh(x) - np.cos(x)) / 2, (np.sinh(x) - np.sin(x)) / 2
    return np.array([[S, T / b, U / (b * b * EI), V / (b**3 * EI)],
                     [b * V, S, T / (b * EI), U / (b * b * EI)],
                     [EI * b * b * U, EI * b * V, S, T / b],
                     [EI * b**3 * T, EI * b * b * U, b * V, S]])


def _stepped_cantilever_hz(segments, n_modes: int) -> list[float]:
    """First natural frequencies [Hz] of a clamped-free stepped beam: segments (EI, m, l, point
    mass at its right end [kg]); roots of the free end's M = Q = 0 determinant."""
    def det(f):
        w = 2 * np.pi * f
        T = np.eye(4)
        for EI, m, l, mp in segments:
            P = np.eye(4)
            P[3, 0] = mp * w * w   # the shear jumps by m_p omega^2 w at a point mass
            T = P @ _field(EI, m, l, w) @ T
        return np.linalg.det(T[2:, 2:])
    f = np.linspace(1.0, 1000.0, 2000)
    d = np.array([det(x) for x in f])
    roots = [brentq(det, f[i], f[i + 1]) for i in np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:]))]
    return roots[:n_modes]


def test_lap_joint_al_modes_lie_between_the_slip_and_bonded_stepped_beam(capsys):
    """The assembly is a stepped cantilever: one layer, the 50.8 mm overlap of two, one layer, with
    the bolts as point masses. With the bolted overlap stuck its bending stiffness lies between two
    layers bending apart (slip, 2 EI) and one bonded section twice as thick (8 EI), so modes 1 and 2
    of the model must lie between the exact frequencies of those two stepped beams (20.82..20.98 Hz,
    122.3..129.7 Hz); the FE model has more than the stepped beam, the beams' axial inertia driven
    by the joint's eccentric rotation, which lowers the modes a little (mode 3 falls 0.7 % below
    both limits, so it is not checked). A uniform 6.35 mm cantilever of the same length (21.67 Hz)
    is no lower bound: the overlap and the bolts add 48 g near the middle."""
    s = _json(capsys, ["--config", str(LAP_AL), "modes", "--json"])
    cfg = load(LAP_AL)
    a, b = cfg.plant.beams
    itf = cfg.plant.interface
    EI1, m1 = a.E * a.width_m * a.height_m**3 / 12, a.rho * a.width_m * a.height_m
    x1, x2 = sorted(sc.x_m for sc in cfg.plant.screws)
    m_bolt = cfg.plant.screws[0].mass_kg
    limits = []
    for k in (2.0, 8.0):   # slip, bonded
        segs = [(EI1, m1, itf.x_start_m, 0.0), (k * EI1, 2 * m1, x1 - itf.x_start_m, m_bolt),
                (k * EI1, 2 * m1, x2 - x1, m_bolt), (k * EI1, 2 * m1, itf.x_end_m - x2, 0.0),
                (EI1, m1, b.x0_m + b.length_m - itf.x_end_m, 0.0)]
        limits.append(_stepped_cantilever_hz(segs, 2))
    lo, hi = np.array(limits)
    f = np.array(s["full_stuck_hz"][:2])
    assert np.all(lo < f) and np.all(f < hi), (lo, f, hi)
    assert s["closed_pairs"] == list(range(17))   # 3937 N per bolt closes the whole overlap (3.175 mm points)


@pytest.mark.parametrize("argv", [["simulate", "--freq", "100", "--amp", "1"], ["compare"], ["observer"],
                                  ["frf", "--law", "passive", "--amp", "1", "--freqs", "100"],
                                  ["rig", "--effect", "none", "-o", "NEW"], ["bench", "loop"]])
def test_actuator_commands_refuse_in_one_line(argv, tmp_path, capsys):
    argv = [str(tmp_path / "campaign") if a == "NEW" else a for a in argv]
    assert main(["--config", str(LAP_AL), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs an adaptive screw (a plant.screws entry with adaptive = true)" in err[0], err
    assert "this structure has none" in err[0] and err[0].startswith(f"frictionrt: error: {argv[0]}")
    assert not (tmp_path / "campaign").exists()


def test_impulse_without_adaptive_screw_or_interface(capsys):
    """The bare beam has no friction: the hammer test identifies its modes at the FE frequencies
    themselves, the step's modes being period-matched (docs/plant.md 2.2; the plain 21 kHz trapezoid
    showed them at (2/h) arctan(Omega h / 2), mode 5 at 633 Hz -0.30 %), with the modal damping
    plant.modal_damping (0.1 %); --fn1 has nothing to set and is refused."""
    res = _json(capsys, ["--config", str(BARE), "impulse", "--json"])
    modes = _json(capsys, ["--config", str(BARE), "modes", "--json"])["preloaded_stuck_hz"]   # the stepped (reduced) model
    f_fe = np.array([modes[m - 1] for m in res["modes"]])
    # the identification of a linear mode: measured within 3e-5 (frequency) and 0.6 % (damping)
    np.testing.assert_allclose(res["freq_hz"], f_fe, rtol=1e-4)
    np.testing.assert_allclose(res["damping_ratio"], 0.001, rtol=0.01)
    # the lap joint's bolts keep the overlap stuck under the 50 N hammer: its modes are the
    # preloaded stuck model's (the stuck contact couples the period-matched modes, so the match is
    # not exact; the interface dashpots add damping of their own, so no damping check)
    res = _json(capsys, ["--config", str(LAP_AL), "impulse", "--json"])
    modes = _json(capsys, ["--config", str(LAP_AL), "modes", "--json"])["preloaded_stuck_hz"]
    f_fe = np.array([modes[m - 1] for m in res["modes"]])
    np.testing.assert_allclose(res["freq_hz"], f_fe, rtol=2e-3)
    assert main(["--config", str(BARE), "impulse", "--fn1", "100"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no adaptive screw" in err[0]


def test_frf_files_and_diagnose_without_adaptive_screw(tmp_path, capsys):
    """rig --frf-files writes one test at F_N1_N = 0 (nothing to hold); diagnose names a hidden
    clamp compliance on the bare beam and, on the lap joint, lists moving_mass as not tried
    because there is no adaptive screw to carry it."""
    d = tmp_path / "bare"
    assert main(["--config", str(BARE), "rig", "--effect", "clamp_compliance", "--frf-files", "-o", str(d)]) == 0
    capsys.readouterr()
    assert sorted(p.name for p in d.iterdir()) == ["frf_01.csv", "frf_01.json"]
    assert json.loads((d / "frf_01.json").read_text())["F_N1_N"] == 0.0
    res = _json(capsys, ["--config", str(BARE), "diagnose", str(d), "--json"])
    assert res["named_effect"] == "clamp_compliance", res["ranking"]
    assert res["gap_after"]["structure_frf_db"] * 3 < res["gap_before"]["structure_frf_db"]
    assert "adaptive screw" in res["not_tried_reasons"]["moving_mass"]

    d = tmp_path / "lap"
    assert main(["--config", str(LAP_AL), "rig", "--effect", "none", "--frf-files", "-o", str(d)]) == 0
    capsys.readouterr()
    res = _json(capsys, ["--config", str(LAP_AL), "diagnose", str(d), "--json"])
    assert res["named_effect"] is None and "moving_mass" in res["not_tried"]
    assert "has none" in res["not_tried_reasons"]["moving_mass"]
    # the nominal model on its own scattered truth: modes 1-5 found within the scatter of E (2 %)
    loc = res["localisation"]["frf_01"]["modes"]
    assert all(abs(loc[str(m)]["shift_rel"]) < 0.04 for m in range(1, 6)), loc


@pytest.mark.parametrize("path", [BARE, LAP_AL], ids=["bare", "lap_al"])
def test_every_output_is_written_without_an_adaptive_screw(path):
    """The plant step writes every output row, dF_N1 (0) included, where there is no adaptive screw:
    an unwritten row held whatever np.empty left there, and plant.simulate.run refused the run as
    NaN in about one of three processes (the row prefilled with NaN catches it every time)."""
    from frictionrt.plant.model import build_plant
    from frictionrt.plant.newmark import _plant_step
    model = build_plant(load(path))
    x = model.initial_state(0.0)
    x_next, y = np.full_like(x, np.nan), np.full(len(model.output_labels()), np.nan)
    _plant_step(0, x, np.array([1.0, 0.0]), model.params, x_next, y, model.new_work())
    assert np.all(np.isfinite(x_next)) and np.all(np.isfinite(y)), [
        model.output_labels()[i] for i in np.nonzero(~np.isfinite(y))[0]]
