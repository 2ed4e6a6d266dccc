"""The quasi-static modes condensed onto the subspace the step reaches (plant.model.condense_quasi_static,
docs/plant.md 2.7): the same plant, fewer coordinates."""
import numpy as np
import pytest

from frictionrt.plant.modes import adaptive_screw_k_T
from frictionrt.plant.model import build_plant, stuck_frequencies_hz
from frictionrt.plant.simulate import run
from frictionrt.rt.common.config import load

DT = 1 / 21000


@pytest.fixture(scope="module")
def pair():
    return {on: build_plant(load(sets=[f"plant.condense_quasi_static={str(on).lower()}"])) for on in (True, False)}


def test_condensed_plant_has_few_coordinates(pair):
    c, f = pair[True], pair[False]
    n_dyn = int(f.params.dyn.sum())
    assert int(c.params.dyn.sum()) == n_dyn
    # at most 3 loads + 2 per pair + the u_rel pair's load, instead of every mode above quasi_static_hz
    assert c.n - n_dyn <= 3 + 2 * c.n_pairs + 1 < f.n - n_dyn
    # the Ritz frequencies stay among the quasi-static modes' (Rayleigh-Ritz bounds)
    qs = f.omega[f.params.dyn == 0]
    ritz = c.omega[c.params.dyn == 0]
    assert ritz.min() >= qs.min() * (1 - 1e-9) and ritz.max() <= qs.max() * (1 + 1e-9)


def test_condensed_step_is_the_full_step_to_round_off(pair):
    # a sine through mode 3 with noise and a moving F_N1: pairs stick, slip and open; every output
    # of the condensed step equals the full one's to round-off (relative to the signal's range)
    n = 2100
    t = np.arange(n) * DT
    F = 3.0 * np.sin(2 * np.pi * 230 * t) + 0.3 * np.random.default_rng(1).standard_normal(n)
    F_N1 = 20.0 + 10.0 * np.sin(2 * np.pi * 40 * t)
    Y = {on: run(m, F, F_N1)[0] for on, m in pair.items()}
    labels = [nm for nm, _ in pair[True].output_labels()]
    skip = {"newton_iter", "substep_fallbacks"}   # iteration counts may differ by one where |r| meets tol
    for j, nm in enumerate(labels):
        if nm in skip:
            continue
        a, b = Y[True][:, j], Y[False][:, j]
        scale = max(np.max(np.abs(b)), 1e-300)
        assert np.max(np.abs(a - b)) <= 1e-8 * scale, nm
    # and the joint did slip (the test is not of a linear run)
    assert Y[False][:, labels.index("E_fric")][-1] > 0.0


def test_condensed_statics_and_stiffness_at_the_screw(pair):
    c, f = pair[True], pair[False]
    assert adaptive_screw_k_T(c) == pytest.approx(adaptive_screw_k_T(f), rel=1e-9)
    # linear analyses that include the quasi-static modes' inertia move only by that inertia
    np.testing.assert_allclose(stuck_frequencies_hz(c)[:6], stuck_frequencies_hz(f)[:6], rtol=2e-5)
    # the initial static state: the gaps of all pairs
    sc, sf = c.state_slots()["g"], f.state_slots()["g"]
    np.testing.assert_allclose(c.initial_state()[sc], f.initial_state()[sf], rtol=0, atol=1e-18)
