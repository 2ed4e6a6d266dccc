"""The shaker's electrical port (plant/shaker.py): the two-port in current and voltage mode on a
single-DOF structure against an independent linear solve of the coupled coil-armature-stinger-structure
equations and against the closed forms of a rigid stinger (the coil's input impedance, the drive
point's velocity per volt, the back-EMF damping Bl^2 / R at the drive point), the power balance
(electrical in = resistive + mechanical, mechanical = what the dampers dissipate), and the
current-drive limit (R -> infinity at a fixed drive current: force = Bl i, today's constant force
scale with a massless armature)."""

import numpy as np
import pytest

from frictionrt.plant.shaker import (
    armature_stiffness,
    check_shaker,
    drive_point_stiffness,
    electrical_impedance,
    force_ratio,
    harmonic_response,
    suspension,
)
from frictionrt.rt.common.config import Config, ConfigError, with_sets

F = np.geomspace(5.0, 3000.0, 61)                   # [Hz] lines across the flexure, structure, coil and stinger
M_S, F_S, ZETA_S = 0.5, 150.0, 0.01                 # the single-DOF structure: 0.5 kg at 150 Hz, 1 %
K_S = M_S * (2 * np.pi * F_S) ** 2
C_S = 2 * ZETA_S * M_S * 2 * np.pi * F_S


def sdof_receptance(f):
    """w / F [m/N] of the single-DOF structure."""
    w = 2 * np.pi * f
    return 1.0 / (K_S - M_S * w * w + 1j * w * C_S)


def shaker(amplifier: str, *sets) -> Config:
    return with_sets(Config(), ["shaker.armature_mass_kg=0.1", f"shaker.amplifier={amplifier}", *sets])


@pytest.mark.parametrize("amplifier", ["current", "voltage"])
def test_two_port_matches_a_linear_solve_of_the_coupled_equations(amplifier):
    """Unknowns [i, x_a, w] per line: coil (voltage mode: Z_e i + Bl i omega x_a = V = R drive / Bl;
    current mode: i = drive / Bl), armature D_a x_a + k~ (x_a - w) = Bl i, structure D_s w = k~ (x_a - w),
    solved by numpy; the module's closed form to rounding (1e-9)."""
    cfg = shaker(amplifier)
    s = cfg.shaker
    Bl, R, L = s.force_constant_N_per_A, s.coil_resistance_ohm, s.coil_inductance_H
    k_a, c_a = suspension(cfg)
    drive = 3.0
    got = harmonic_response(cfg, F, sdof_receptance(F), drive)
    for j, f in enumerate(F):
        w = 2 * np.pi * f
        D_a = k_a + 1j * w * c_a - s.armature_mass_kg * w * w
        D_s = K_S + 1j * w * C_S - M_S * w * w
        ks = s.stinger_N_per_m + 1j * w * s.stinger_damping_Ns_per_m
        A = np.array([[R + 1j * w * L, 1j * w * Bl, 0.0], [-Bl, D_a + ks, -ks], [0.0, -ks, ks + D_s]], complex)
        b = np.array([R * drive / Bl, 0.0, 0.0], complex)
        if amplifier == "current":
            A[0] = [1.0, 0.0, 0.0]
            b[0] = drive / Bl
        i, x_a, w_s = np.linalg.solve(A, b)
        assert got.i[j] == pytest.approx(i, rel=1e-9)
        assert got.x_a[j] == pytest.approx(x_a, rel=1e-9)
        assert got.w[j] == pytest.approx(w_s, rel=1e-9)
        assert got.F_exc[j] == pytest.approx(ks * (x_a - w_s), rel=1e-8)
    assert np.ptp(np.abs(got.F_exc / drive)) > 0.5        # not an ideal source: the check can fail


def test_rigid_stinger_closed_forms_and_the_back_emf_damping():
    """Stinger 1e15 N/m, undamped: the coil's input impedance V / i = Z_e + Bl^2 / (Z_a + Z_s) and the
    drive point's velocity per volt v / V = Bl / (Z_e (Z_a + Z_s) + Bl^2) (Z = D / (i omega), mechanical
    impedances) within 1e-6 (the stinger's compliance, |D| / k_s <= 2e-7 here); the shaker's dynamic
    stiffness at the drive point has the damping c_a + Bl^2 R / (R^2 + omega^2 L^2), i.e. c_a + Bl^2 / R
    below the electrical corner (0.02 % off at 10 Hz); none of the back-EMF in current mode."""
    cfg = shaker("voltage", "shaker.stinger_N_per_m=1e15", "shaker.stinger_damping_Ns_per_m=0.0")
    s = cfg.shaker
    Bl, R, L = s.force_constant_N_per_A, s.coil_resistance_ohm, s.coil_inductance_H
    k_a, c_a = suspension(cfg)
    w = 2 * np.pi * F
    Z_a = (k_a + 1j * w * c_a - s.armature_mass_kg * w * w) / (1j * w)
    Z_s = (K_S + 1j * w * C_S - M_S * w * w) / (1j * w)
    Z_e = R + 1j * w * L
    got = harmonic_response(cfg, F, sdof_receptance(F), drive=1.0)
    np.testing.assert_allclose(got.V / got.i, Z_e + Bl ** 2 / (Z_a + Z_s), rtol=1e-6)
    np.testing.assert_allclose(1j * w * got.w / got.V, Bl / (Z_e * (Z_a + Z_s) + Bl ** 2), rtol=1e-6)
    c_drive = drive_point_stiffness(cfg, F).imag / w
    np.testing.assert_allclose(c_drive, c_a + Bl ** 2 * R / (R ** 2 + (w * L) ** 2), rtol=1e-6)
    assert c_drive[0] == pytest.approx(c_a + s.back_emf_damping_Ns_per_m, rel=2e-4)
    assert s.back_emf_damping_Ns_per_m == pytest.approx(10.0 ** 2 / 1.5)              # the defaults' 67 N s/m
    current = with_sets(cfg, ["shaker.amplifier=current"])
    np.testing.assert_allclose(drive_point_stiffness(current, F).imag / w, c_a, rtol=1e-6)
    assert current.shaker.back_emf_damping_Ns_per_m == 0.0


@pytest.mark.parametrize("amplifier", ["current", "voltage"])
def test_power_balance(amplifier):
    """Time-averaged powers of the harmonic steady state: electrical in 1/2 Re(V i*) = resistive 1/2 R |i|^2
    + mechanical 1/2 Re(F_coil v_a*) (the inductance stores, never dissipates), and the mechanical =
    what the flexure's, the stinger's and the structure's dampers dissipate, to rounding (1e-9 of the input)."""
    cfg = shaker(amplifier)
    s = cfg.shaker
    _, c_a = suspension(cfg)
    got = harmonic_response(cfg, F, sdof_receptance(F), drive=2.0)
    w = 2 * np.pi * F
    v_a, v_s = 1j * w * got.x_a, 1j * w * got.w
    p_in = 0.5 * np.real(got.V * np.conj(got.i))
    p_res = 0.5 * s.coil_resistance_ohm * np.abs(got.i) ** 2
    p_mech = 0.5 * np.real(got.F_coil * np.conj(v_a))
    p_damp = 0.5 * (c_a * np.abs(v_a) ** 2 + s.stinger_damping_Ns_per_m * np.abs(v_a - v_s) ** 2
                    + C_S * np.abs(v_s) ** 2)
    np.testing.assert_allclose(p_in, p_res + p_mech, rtol=1e-9)
    np.testing.assert_allclose(p_mech, p_damp, rtol=1e-9)
    assert np.all(p_damp > 0)


def test_current_drive_limit():
    """Voltage mode with R -> infinity at a fixed drive (the blocked coil's DC force Bl V / R, i.e. a fixed
    current): the back-EMF term i omega Bl^2 / Z_e and the coil's pole vanish like 1 / R, so the force per
    drive tends to current mode's (error x 1/10 per decade of R, measured ratios 9.96, 10.00); the coil force is
    Bl i throughout. With a massless armature on a rigid stinger current mode is the ideal source: the
    constant force scale of FRF files per volt."""
    R_s = sdof_receptance(F)
    ref = force_ratio(shaker("current"), F, R_s)
    err = []
    for R in (1.5e3, 1.5e4, 1.5e5):
        v = shaker("voltage", f"shaker.coil_resistance_ohm={R}")
        err.append(np.max(np.abs(force_ratio(v, F, R_s) / ref - 1.0)))
        got = harmonic_response(v, F, R_s, drive=1.0)
        np.testing.assert_allclose(got.F_coil, v.shaker.force_constant_N_per_A * got.i, rtol=1e-12)
        np.testing.assert_allclose(got.i, 1.0 / v.shaker.force_constant_N_per_A, rtol=100.0 / R)
    assert err[0] / err[1] == pytest.approx(10.0, rel=0.05) and err[1] / err[2] == pytest.approx(10.0, rel=0.05)
    assert err[-1] < 1e-4, err
    ideal = shaker("current", "shaker.armature_mass_kg=1e-9", "shaker.stinger_N_per_m=1e12")
    np.testing.assert_allclose(force_ratio(ideal, F, R_s), 1.0, atol=1e-5)
    # voltage mode's blocked coil: the electrical pole R / Z_e, 1/sqrt(2) at R / (2 pi L)
    v = shaker("voltage")
    corner = v.shaker.coil_resistance_ohm / (2 * np.pi * v.shaker.coil_inductance_H)
    assert abs(v.shaker.coil_resistance_ohm / electrical_impedance(v, 2 * np.pi * corner)) == pytest.approx(2 ** -0.5)
    assert armature_stiffness(v, np.array([0.0]))[0] == pytest.approx(suspension(v)[0])


def test_voltage_mode_is_refused_in_the_loop_and_a_bad_amplifier_named():
    """The loop's time-domain stage is current mode's: voltage mode is refused by name, not run wrong."""
    with pytest.raises(ValueError, match="shaker.amplifier = 'voltage'"):
        check_shaker(shaker("voltage"))
    with pytest.raises(ConfigError, match="shaker.amplifier = 'volts': must be one of current, voltage"):
        shaker("volts")
