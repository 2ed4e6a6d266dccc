"""Pairing measured modes with the model's (rt.discrepancy.diagnose.frf_modes, issue 18): by order with the
offset that pairs most modes at one frequency ratio, by shape (MAC) with three or more sensors;
no window around the model's frequencies, so a model 33 % off still pairs every mode."""
import numpy as np

from frictionrt.rt.discrepancy.diagnose.frf_modes import Measured, ModelModes, mac, pair

F_MODEL = np.array([9.7, 74.4, 230.7, 416.2, 634.7, 1049.7, 1420.7, 1547.9])   # the benchmark's stuck modes [Hz]


def test_order_pairing_33_percent_off_with_the_band_above_mode_1():
    """The data 33 % above the model and their band starting at 50 Hz (mode 1 not measured): the
    offset +1 pairs all seven measured modes at the ratio 1.33; offset 0 would pair none."""
    meas = Measured(1.33 * F_MODEL[1:], np.ones((7, 2), complex))
    f, m = pair(meas, ModelModes(F_MODEL, np.ones((8, 2)), np.ones(8, bool)))
    assert np.isnan(f[0]) and np.allclose(f[1:] / F_MODEL[1:], 1.33) and np.all(np.isnan(m))


def test_order_pairing_skips_invisible_model_modes():
    """Mode 3 has a node at the excitation (not visible): the measured modes pair with 1, 2, 4, ..."""
    vis = np.ones(8, bool)
    vis[2] = False
    meas = Measured(0.75 * F_MODEL[vis], np.ones((7, 2), complex))
    f, _ = pair(meas, ModelModes(F_MODEL, np.ones((8, 2)), vis))
    assert np.isnan(f[2]) and np.allclose(f[vis] / F_MODEL[vis], 0.75)


def test_shape_pairing_finds_the_mode_order_cannot():
    """Three sensors, the model 25 % low and the data missing mode 2 and holding mode 5 only: each
    measured mode goes to the model mode of its shape (MAC 1), whatever their order; a common
    complex factor of the measured shape (a resonance's phase) does not change the MAC."""
    rng = np.random.default_rng(0)
    shapes = rng.standard_normal((8, 3))
    keep = [0, 2, 4, 6, 7]
    meas = Measured(F_MODEL[keep] / 0.75, shapes[keep] * (0.3 - 2.0j))
    f, m = pair(meas, ModelModes(F_MODEL, shapes, np.ones(8, bool)))
    assert np.allclose(f[keep] * 0.75, F_MODEL[keep]) and np.all(np.isnan(f[[1, 3, 5]]))
    assert np.allclose(m[keep], 1.0)
    assert mac(shapes[0], shapes[0] * 1j) == 1.0 and mac(np.array([1.0, 0, 0]), np.array([0, 1.0, 0])) == 0.0
