"""Lumped elements of the structure (plant.structure.add_lumped): point and screw masses and a
compliant clamp, against the exact Euler-Bernoulli frequencies of a cantilever with a tip mass
and with a rotational spring at its root (boundary-value determinant solved independently here)."""
import numpy as np
import pytest
from scipy.optimize import brentq

from frictionrt.plant.fe_beam import DOFS_PER_NODE, W
from frictionrt.plant.model import build_plant
from frictionrt.plant.modes import bare_beam_bending_hz
from frictionrt.rt.common.config import load

E, B, H, RHO, L = 210e9, 0.04, 0.008, 7850.0, 0.775   # the main beam (SPEC 1)
EI, MU = E * B * H**3 / 12, RHO * B * H
FINE = ["plant.element_length_m=0.005"]


def cantilever_hz(n: int, k_root: float = np.inf, m_tip: float = 0.0) -> np.ndarray:
    """First n bending frequencies [Hz] of the main beam clamped at x = 0 (a rotational spring
    k_root [N m/rad] if finite) with a point mass m_tip [kg] at the free end x = L.

    w = a1 cos bx + a2 sin bx + a3 cosh bx + a4 sinh bx, omega^2 = b^4 EI / mu; conditions
    w(0) = 0, EI w''(0) = k_root w'(0) (w'(0) = 0 if rigid), w''(L) = 0,
    EI w'''(L) = -m_tip omega^2 w(L) (shear against the mass's inertia)."""
    def det(b):
        c, s, ch, sh = np.cos(b * L), np.sin(b * L), np.cosh(b * L), np.sinh(b * L)
        w2 = b**4 * EI / MU
        root = [0, 1, 0, 1] if np.isinf(k_root) else [-EI * b**2, -k_root * b, EI * b**2, -k_root * b]
        tip = [EI * b**3 * s + m_tip * w2 * c, -EI * b**3 * c + m_tip * w2 * s,
               EI * b**3 * sh + m_tip * w2 * ch, EI * b**3 * ch + m_tip * w2 * sh]
        return np.linalg.det(np.array([[1, 0, 1, 0], root, [-c, -s, ch, sh], tip], float))
    grid = np.linspace(0.5, 20.0, 8000)
    vals = [det(b) for b in grid]
    betas = [brentq(det, a, b) for a, b, fa, fb in zip(grid, grid[1:], vals, vals[1:]) if fa * fb < 0][:n]
    return np.array(betas) ** 2 * np.sqrt(EI / MU) / (2 * np.pi)


def test_tip_mass_lowers_the_cantilever_frequencies_as_theory_says():
    # 0.1 kg (5 % of the beam's 1.95 kg) at the free end: 11.13 -> 10.13 Hz, 69.7 -> 64.3 Hz
    cfg = load(None, FINE + ["plant.points.tip.x_m=0.775", "plant.points.tip.mass_kg=0.1"])
    f_fe = bare_beam_bending_hz(build_plant(cfg, reduced=False), "main", 3)
    f_exact = cantilever_hz(3, m_tip=0.1)
    assert np.allclose(f_fe, f_exact, rtol=1e-5)          # measured 3e-7 (FE mesh error)
    assert np.all(f_exact < cantilever_hz(3) * 0.95)      # and the mass matters


def test_compliant_clamp_matches_the_rotational_spring_cantilever(tmp_path):
    # 2e-3 rad/(N m), i.e. 500 N m/rad: the first mode falls from 11.1 to 5.09 Hz
    toml = tmp_path / "clamp.toml"
    toml.write_text('[[plant.clamps]]\nbeam = "main"\nx_m = 0.0\nrot_compliance_rad_per_Nm = 0.002\n')
    f_fe = bare_beam_bending_hz(build_plant(load(toml, FINE), reduced=False), "main", 3)
    assert np.allclose(f_fe, cantilever_hz(3, k_root=500.0), rtol=1e-5)   # measured 6e-7
    assert f_fe[0] < 0.5 * cantilever_hz(1)[0]


def test_screw_mass_sits_on_the_upper_beam_and_defaults_change_nothing():
    base, heavy = load(), load(None, ["plant.screws.adaptive.mass_kg=0.02"])
    s0, s1 = (next(s for s in build_plant(c, reduced=False).structure.subs if s.beam.name == "damper")
              for c in (base, heavy))
    w_dofs = s0.free % DOFS_PER_NODE == W
    # a rigid translation's kinetic mass: the sum of the transverse mass matrix entries
    ones = w_dofs.astype(float)
    assert ones @ s1.M @ ones - ones @ s0.M @ ones == pytest.approx(0.02, rel=1e-12)
    main0, main1 = (next(s for s in build_plant(c, reduced=False).structure.subs if s.beam.name == "main")
                    for c in (base, heavy))
    np.testing.assert_array_equal(main0.M, main1.M)        # the lower beam is untouched
