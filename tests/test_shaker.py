"""The shaker stage of the loop (plant/shaker.py): its force ratio F_exc / drive in the closed loop
against the closed-form two-port of armature + stinger on the stuck structure's driving point
(plant.linear_frf, an independent linear solve), the ideal source when off, and the design-time
refusal of a coupling that would be unstable."""

import numpy as np
import pytest

from frictionrt.plant.linear_frf import continuous_accelerance, stuck_model
from frictionrt.plant.model import build_plant
from frictionrt.plant.modes import sliding_joint_hz
from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.loop import build_loop, run
from frictionrt.plant.shaker import coupled_spectral_radius, force_ratio
from frictionrt.rt.experiments.stepsine import settle_point

# every mode stepped: the driving point is then the stuck model's at the trapezoid's warped frequency
STUCK = ["shaker.armature_mass_kg=0.1", "tracking.F_passive_N=300.0", "plant.screws.adaptive.F_N=300.0",
         "plant.quasi_static_hz=1e9"]


def test_force_ratio_matches_the_two_port_on_the_stuck_structure():
    """300 N, 1 N: the joint stays stuck, the structure is the linear stuck model. The step-sine's
    measured F_amp / drive against 1 / (1 + D_a / k~ + D_a R), R = the continuous driving-point
    receptance of the stuck model. Lines away from the lightly damped stuck resonances (there the
    amplitude controller needs longer than a test should run). Tolerance 0.5 %: the plant's
    trapezoidal warping and held force move R by up to 0.3 % at 360-500 Hz (measured 0.02-0.3 %)."""
    cfg = with_sets(Config(), STUCK)
    loop = build_loop(cfg, "passive")
    lin = stuck_model(loop.plant, cfg.plant.excitation_point, 300.0)
    state, rows = None, []
    for f in (100.0, 150.0, 360.0, 500.0):
        p, state = settle_point(loop, f, 1.0, start=state)
        assert p.settled, f
        R = continuous_accelerance(lin, f)[0] / -(2 * np.pi * f) ** 2
        rows.append((f, p.F_amp / p.drive_amp, abs(force_ratio(cfg, f, R)[0]), abs(p.R_exc / R - 1.0)))
    for f, meas, two_port, r_err in rows:
        assert meas == pytest.approx(two_port, rel=5e-3), rows
        # the loop's own driving point (the step-sine's R_exc) is the stuck model's at f itself: the
        # step's modes are period-matched (docs/plant.md 2.2; the plain trapezoid showed it at the warped
        # frequency tan(pi f dt) / (pi dt), 3-4 % off unwarped at 360-500 Hz near the lightly damped mode)
        assert r_err < 1e-2, rows
    ratios = [r[1] for r in rows]
    assert min(ratios) < 0.95 and max(ratios) > 1.05, rows   # not an ideal source: the test can fail


def test_drop_out_at_a_slipping_resonance_and_ideal_source_when_off():
    """100 N, 10 N at the friction-softened mode 4 (the model's own: the adaptive joint sliding at
    100 N, 381.2 Hz on the 10 mm plant; stuck 417 Hz): near it the force drops out, the amplitude controller raises the drive
    to hold 10 N (measured: ratio 0.917, 0.80 at its minimum near 390 Hz; the rattling plant
    before issue 15 gave 0.589). With armature_mass_kg = 0 the logged F_exc is the generator's
    sine, bit for bit."""
    cfg = with_sets(Config(), ["shaker.armature_mass_kg=0.1", "tracking.F_passive_N=100.0"])
    f4 = float(sliding_joint_hz(build_plant(cfg), 100.0)[3])
    loop = build_loop(cfg, "passive")
    # the slipping resonance lies near the sliding joint's linear picture, not on it: the lowest ratio
    # of five lines over +-4 % (measured on the 10 mm plant: 1.21, 1.30, 1.19, 0.88, 0.82 at 366-396 Hz)
    pts = [settle_point(loop, f, 10.0)[0] for f in f4 * np.linspace(0.96, 1.04, 5)]
    p = min(pts, key=lambda q: q.F_amp / q.drive_amp)
    assert p.settled and p.F_amp == pytest.approx(10.0, rel=0.02), (p.F_amp, p.drive_amp)
    assert p.F_amp / p.drive_amp < 0.95, [(q.F_amp, q.drive_amp) for q in pts]
    off = build_loop(with_sets(Config(), ["shaker.armature_mass_kg=0.0"]), "passive")
    r = run(off, 200.0, 3.0, 0.01)
    k = np.arange(len(r.log))
    assert np.array_equal(r.signal("F_exc"), 3.0 * np.sin(2 * np.pi * 200.0 * (k * off.cfg.dt_s)))


def test_unstable_coupling_is_refused_at_design_time():
    """The one-tick lag on a 2e8 N/m stinger feeds more energy in than the shaker dissipates
    (spectral radius 2.64; 5e7 and 1e8 N/m stay at 0.99999 on the bolted plant)."""
    stiff = with_sets(Config(), ["shaker.armature_mass_kg=0.1", "shaker.stinger_N_per_m=2e8"])
    assert coupled_spectral_radius(stiff) > 1.0
    assert coupled_spectral_radius(with_sets(Config(), ["shaker.armature_mass_kg=0.1"])) < 1.0
    with pytest.raises(ValueError, match="stinger_N_per_m"):
        build_loop(stiff, "passive")
