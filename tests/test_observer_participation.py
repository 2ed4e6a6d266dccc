"""The amplitude-following observer's participation (observer/amplitude.py ``participation``, the
seventh column of its blocks): mode 5's rows of C_u, C_v and its friction input scaled by the
plant's U_rel / V_meas against the amplitude (on the observer as a linear filter); the kernel applies it as a model with those rows would
(checked against the same kernel on a model with the rows scaled and p = 1); and its C export is
bit-exact with a participation away from 1 at every amplitude."""
import dataclasses

import numpy as np
import pytest

from frictionrt.observer.amplitude import (AMP_GRID_M, PLANT_RATIOS, AmplitudeParams, design_amplitude,
                                           filter_ratio, participation)
from frictionrt.rt.common.config import load


@pytest.fixture(scope="module")
def designed():
    """(cfg, design, params) of the amplitude kind at spring scale 0.1 on the default plant."""
    cfg = load()
    d, a = design_amplitude(cfg, spring_scale=0.1)
    return cfg, d, a


def test_participation_puts_the_plants_ratio_on_the_filter_and_is_folded_into_bd(designed):
    """At each point (f, U, rho) the observer as a linear filter with mode 5's rows times p has the
    plant's |U_rel / V_meas| at f (independently: the filter's response with those rows scaled); p
    grows with the amplitude where the plant's ratio does at one frequency (the 5 and 10 N points,
    both at 615.87 Hz), is held beyond the points, and is 1 elsewhere."""
    cfg, d, a = designed
    N = len(d.model.omega)
    assert a.blocks.shape == (N, len(AMP_GRID_M), 7)
    p = a.blocks[:, :, 6]
    pts = PLANT_RATIOS[5]
    assert np.all(p[[0, 1, 2, 3, 5, 6]] == 1.0)
    assert p[4, 0] == p[4, 1] and p[4, -1] == p[4, -2]
    facs = []
    for f_hz, U, rho in pts:
        fac = participation(d.params, cfg.dt_s, (0.0, 1.0), {5: ((f_hz, U, rho),)})[4, 0]
        scaled = d.params._replace(C_u=d.params.C_u * np.where(np.arange(2 * N) % N == 4, fac, 1.0))
        U_o, U_m = filter_ratio(scaled, 5, f_hz, cfg.dt_s)
        assert abs(U_o + U_m) == pytest.approx(rho, rel=1e-12)
        facs.append(fac)
        # the kernel's p at the point's own amplitude coordinate U / p is that factor
        assert np.interp(U / fac, AMP_GRID_M, p[4]) == pytest.approx(fac, rel=0.05)
    # the model's own filter ratio at 0.1 is below the plant's at both 615.87 Hz points (what p corrects)
    (f0, _, rho0), (f1, _, rho1) = pts[:2]
    assert f0 == f1
    U_o, U_m = filter_ratio(d.params, 5, f0, cfg.dt_s)
    assert abs(U_o + U_m) < rho0 < rho1 and 1.0 < facs[0] < facs[1] < 1.3
    # the friction's input column of mode 5 is p times the unscaled one (the ZOH is linear in b)
    plain = design_amplitude(cfg, spring_scale=0.1, ratios={})[1]
    assert np.all(plain.blocks[:, :, 6] == 1.0)
    np.testing.assert_array_equal(plain.blocks[:, :, :4], a.blocks[:, :, :4])
    np.testing.assert_allclose(a.blocks[4, :, 4:6], p[4][:, None] * plain.blocks[4, :, 4:6], rtol=1e-12, atol=0.0)


def test_the_kernel_applies_the_participation_to_the_outputs_and_the_friction():
    """A constant participation c on every mode (and bd times c, as the design folds it) equals the
    kernel with c C_u, c C_v and p = 1 (to rounding), over 400 ticks of a sine on the tip and a varying normal force; and it differs
    from p = 1 (not vacuous)."""
    from frictionrt.observer.amplitude_step import _amplitude_step
    cfg = load()
    d, a = design_amplitude(cfg, spring_scale=0.1, ratios={})
    c = 1.3
    scaled = a.blocks.copy()
    scaled[:, :, 4:6] *= c            # the friction's input, as the design folds p into bd
    with_p = scaled.copy()
    with_p[:, :, 6] = c
    p_scaled = d.params._replace(C_u=c * d.params.C_u, C_v=c * d.params.C_v)
    n = len(d.params.M)

    def run(p, blocks):
        amp = AmplitudeParams(a.grid, blocks, a.scale, a.inv_omega, a.k_j)
        x, x_next, w, y = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(4)
        out = np.empty((400, 4))
        for k in range(400):
            t = k * cfg.dt_s
            u = np.array([2e-3 * np.sin(2 * np.pi * 370.0 * t), 500.0 + 50.0 * np.sin(2 * np.pi * 40.0 * t)])
            _amplitude_step(k, x, u, p, amp, w, x_next, y)
            x, x_next = x_next, x
            out[k] = y
        return out

    ref, got, plain = run(p_scaled, scaled), run(d.params, with_p), run(d.params, scaled)
    for j in range(4):
        np.testing.assert_allclose(got[:, j], ref[:, j], rtol=1e-9, atol=1e-12 * np.max(np.abs(ref[:, j])))
    assert np.max(np.abs(got[:, 0] - plain[:, 0])) > 0.1 * np.max(np.abs(plain[:, 0]))


@pytest.mark.slow   # ~60 s under load; the suite's twin: tests/test_export_amplitude.py (mode 5's p 1.19-1.30 by default)
def test_the_c_export_is_bit_exact_with_a_participation_away_from_one(tmp_path):
    """The hysteresis law on the amplitude kind with mode 5's participation 1.2-1.4 over the grid
    (interpolated at every tick): its export's golden vectors (the numba controller's outputs) pass
    make check."""
    from frictionrt.rt.export.generate import export_c
    from frictionrt.rt.loop import build_loop, initial_loop_state
    from tests.test_export_c import _make_check
    cfg = load()
    loop = build_loop(cfg, "hysteresis", "amplitude")
    amp = design_amplitude(cfg, loop.plant)[1]
    amp = amp._replace(blocks=amp.blocks.copy())
    amp.blocks[4, :, 6] = np.linspace(1.2, 1.4, amp.blocks.shape[1])   # away from 1 at every amplitude
    loop = dataclasses.replace(loop, amplitude=amp)
    m = export_c(loop, initial_loop_state(loop, cfg.rt.seed), tmp_path / "c", "participation 1.3")
    code, line = _make_check(tmp_path / "c", tmp_path, "participation")
    assert code == 0 and line == f"ok: 3150 ticks x 13 outputs bit-exact, design {m['design_hash']}", line
