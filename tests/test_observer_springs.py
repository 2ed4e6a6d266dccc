"""The observer model's normal springs under the adaptive screw at a scaled stiffness
(``build_observer_model(..., spring_scale)``, observer/model.py): the scaled model's modes 2-5 match
the plant's own reduced model linearised at F_min with the adaptive joint sliding and its cone's
closed pairs' normal stiffness scaled alike (an independent model: the plant's Craig-Bampton
reduction, not the observer's unreduced FE), within the 0.5 % the unscaled model is held to; the
default (1) is the unscaled model."""
import numpy as np
import pytest
import scipy.linalg as sla

from frictionrt.observer.model import build_observer_model
from frictionrt.plant.model import build_plant, preloaded_pairs
from frictionrt.plant.structure import adaptive_cone_pairs
from frictionrt.rt.common.config import load


@pytest.fixture(scope="module")
def plant():
    return build_plant(load())


def _plant_hz(plant, scale: float) -> np.ndarray:
    """Modes 2-5 [Hz] of the plant linearised at F_min: closed pairs stuck, the cone's tangentially
    free, the cone's closed pairs' normal stiffness x scale."""
    cfg, p = plant.cfg, plant.params
    closed = preloaded_pairs(plant, cfg.tracking.F_min_N)
    cone = adaptive_cone_pairs(cfg, plant.structure.x_pairs)
    k = np.zeros(p.G.shape[0])
    k[0::2] = p.k_n * closed * np.where(cone, scale, 1.0)
    k[1::2] = p.k_t * (closed & ~cone)
    f = np.sqrt(np.maximum(sla.eigvalsh(np.diag(p.omega2) + (p.G.T * k) @ p.G), 0.0)) / (2 * np.pi)
    return f[f > 1e-3][1:5]


def test_scaled_normal_springs_match_the_plant_softened_alike(plant):
    cfg = plant.cfg
    base = build_observer_model(cfg, plant)
    assert np.array_equal(build_observer_model(cfg, plant, 1.0).omega, base.omega)
    soft = build_observer_model(cfg, plant, 0.1)
    f_soft = soft.modes_hz[1:5]
    assert np.all(np.abs(f_soft / _plant_hz(plant, 0.1) - 1) < 0.005)
    assert np.all(np.abs(base.modes_hz[1:5] / _plant_hz(plant, 1.0) - 1) < 0.005)
    # not vacuous: the softening moves modes 4 and 5 by more than the tolerance (380.7 -> 375.2 Hz, 621.8 -> 617.4)
    assert np.all(f_soft[2:] < base.modes_hz[3:5] * 0.995)
    # and raises u_rel per modal tip velocity of mode 5 (the u_rel / v_tip transfer the estimate scales by)
    N = len(soft.omega)
    ratio = [abs(m.C_u[4] / m.C_meas[N + 4]) for m in (base, soft)]
    assert ratio[1] > 1.05 * ratio[0]


def test_rebased_peaks_keep_each_scheduled_frequency():
    """The amplitude kind's points re-based onto another model's frequencies schedule the same
    peak [Hz] at each point's amplitude: r' f_model = r f_reference."""
    from frictionrt.observer.amplitude import PLANT_PEAKS, rebased_peaks
    ref = np.array([9.7, 71.49, 202.51, 380.47, 621.93])
    model = np.array([9.7, 71.35, 200.73, 375.25, 617.40])
    new = rebased_peaks(PLANT_PEAKS, ref, model)
    assert set(new) == set(PLANT_PEAKS)
    for m, pts in PLANT_PEAKS.items():
        for (a, r), (a2, r2) in zip(pts, new[m]):
            assert a2 == a and r2 * model[m - 1] == pytest.approx(r * ref[m - 1], rel=1e-15)
    assert new[4][0][1] == pytest.approx(374.76 / 375.25, abs=1e-4)   # mode 4's 5 N peak, now 0.13 % below the model
