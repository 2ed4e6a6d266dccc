"""The fronts layout (plant/layout.py, plant.interface.layout = "fronts"): the hand layout's point
count, its end spacing over the whole closed contact, the slip fronts at a quarter pitch, the open
interface with what is left; nested under refinement like the model layout."""
from __future__ import annotations

import numpy as np
import pytest

from frictionrt.plant import layout, structure
from frictionrt.plant.structure import build_structure
from frictionrt.rt.common.config import load, refined_sets, with_sets


@pytest.fixture(scope="module")
def fronts():
    cfg = load(None, ["plant.interface.layout=fronts"])
    zones = structure._joint_zones(layout.analysis_config(cfg))
    return cfg, zones, build_structure(cfg).x_pairs


def test_as_many_points_as_the_hand_layout(fronts):
    cfg, _, x = fronts
    assert len(x) == len(layout.hand_positions(cfg.plant.interface)) == 23
    assert x[0] == cfg.plant.interface.x_start_m and x[-1] == cfg.plant.interface.x_end_m
    assert np.all(np.diff(x) > 0.0)


def test_closed_contact_at_the_end_spacing_and_fronts_at_a_quarter_pitch(fronts):
    """Every spacing inside the closed contact (a point closed at some level on both sides) is at
    most pitch / end_refinement (5 mm, the hand layout's ends), those among the slip-prone points
    pitch / end_refinement^2 (2.5 mm), and the open interface's larger than the hand's 10 mm (its
    points went to the fronts)."""
    cfg, z, x = fronts
    itf = cfg.plant.interface
    h, r = itf.pitch_m, itf.end_refinement
    closed_x = z.x[z.closed.any(axis=0)]
    runs = np.split(closed_x, np.nonzero(np.diff(closed_x) > 1.5 * np.diff(z.x).max())[0] + 1)
    gaps = np.diff(x)
    mid = 0.5 * (x[1:] + x[:-1])
    in_closed = np.zeros(len(gaps), bool)
    for run in runs:
        in_closed |= (x[:-1] >= run[0] - 1e-12) & (x[1:] <= run[-1] + 1e-12)
    assert in_closed.sum() >= 8 and np.all(gaps[in_closed] <= h / r * (1 + 1e-9))
    prone = z.x[z.slip_prone]
    at_front = (mid > prone.min()) & (mid < prone.max()) & in_closed & (mid > runs[-1][0])
    np.testing.assert_allclose(gaps[at_front], h / r**2, rtol=1e-9)
    assert gaps[~in_closed].max() > h


def test_refined_layout_holds_the_coarse_one(fronts):
    cfg, _, x = fronts
    xr = build_structure(with_sets(cfg, refined_sets(cfg, 2))).x_pairs
    assert len(xr) == 2 * (len(x) - 1) + 1
    np.testing.assert_allclose(xr[0::2], x, rtol=0, atol=1e-12)
