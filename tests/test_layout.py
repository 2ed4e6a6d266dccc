"""The contact layout chosen from the model (plant/layout.py, plant.interface.layout = "model").

The analysis runs here on 32 intervals (5 mm) instead of 128, so that the module's one analysis
costs a few seconds; what is asserted holds at any analysis pitch that resolves the cone.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from frictionrt.plant import layout, structure
from frictionrt.plant.structure import build_structure
from frictionrt.rt.common.config import ConfigError, load, refined_sets, with_sets

HAND_DEFAULT_MM = [465, 470, 475, 480, 485, 490, 495, 505, 515, 525, 535, 545, 555, 565, 575, 585, 595,
                   600, 605, 610, 615, 620, 625]


@pytest.fixture(scope="module")
def coarse_analysis():
    """plant.layout with ANALYSIS_INTERVALS = 32 for this module (its cache cleared around it)."""
    mp = pytest.MonkeyPatch()
    mp.setattr(layout, "ANALYSIS_INTERVALS", 32)
    structure._joint_zones.cache_clear()
    yield layout
    structure._joint_zones.cache_clear()
    mp.undo()


@pytest.fixture(scope="module")
def zones(coarse_analysis):
    cfg = load(None, [])
    return cfg, structure._joint_zones(coarse_analysis.analysis_config(cfg))


def test_the_hand_layout_is_the_default_and_unchanged():
    """The default's 23 points: 5 mm within 30 mm of both ends, 10 mm between (docs/plant.md 6.3)."""
    cfg = load(None, [])
    assert cfg.plant.interface.layout == "hand"
    np.testing.assert_allclose(build_structure(cfg).x_pairs * 1e3, HAND_DEFAULT_MM, atol=1e-9)


def test_a_bad_layout_is_refused_with_its_choices():
    with pytest.raises(ConfigError, match=r"plant.interface.layout = 'fine': must be one of hand, model"):
        load(None, ["plant.interface.layout=fine"])


def test_the_stuck_pressure_carries_both_screws(zones):
    """The damper beam is held by the two screws and the interface alone, so at every level the
    closed points' normal forces add up to the screws' forces, F_N1 + F_N2 less what the screws'
    own springs (docs/plant.md 1.4, in series with the joint) give back as the joint settles from
    the reference state: k_b times the screw's settling, below 0.2 % of the total (0.93 N of 6600 N
    at F_max here); a lost or doubled pair's force would be >= 1 %."""
    cfg, z = zones
    F_N2 = next(s.F_N for s in cfg.plant.screws if not s.adaptive)
    np.testing.assert_allclose(z.f_n.sum(axis=1), z.levels_N + F_N2, rtol=2e-3)
    assert np.all(z.f_n >= 0.0) and np.all(z.f_n[~z.closed] == 0.0)


def test_the_adaptive_contact_grows_toward_the_middle_with_F_N1(zones):
    """Two closed zones, one under each screw; the adaptive screw's inner edge moves toward the
    interface's middle as F_N1 rises from F_min to F_max (its cone presses a wider footprint) and
    stays inside the screw's cone footprint's reach; the normal screw's edge (F_N2 constant) moves
    by less than one analysis interval."""
    cfg, z = zones
    (n_lo, n_hi), (a_lo, a_hi) = z.edges
    x_a = next(s.x_m for s in cfg.plant.screws if s.adaptive)
    h = z.x[1] - z.x[0]
    assert n_hi - n_lo < h
    assert a_hi - a_lo > 2 * h
    assert n_hi < a_lo < a_hi < x_a
    # the order of the levels: F_max's edge is the lowest x
    assert z.closed[-1].sum() > z.closed[0].sum()


def test_slip_starts_at_the_free_end_and_the_contact_edge(zones):
    """Cattaneo-Mindlin: the first points to reach mu f_n are where the pressure falls to zero (the
    closed zones' inner edges) and the overlap's free end at the lightly pressed adaptive screw;
    the middle of the normal screw's contact (pressed by 6 kN) is not slip-prone."""
    cfg, z = zones
    itf = cfg.plant.interface
    prone = z.x[z.slip_prone]
    assert np.isclose(prone.max(), itf.x_end_m)
    x_n = next(s.x_m for s in cfg.plant.screws if not s.adaptive)
    assert not np.any(np.abs(prone - x_n) < 0.005)
    (_, a_hi) = z.edges[1]
    assert np.any(np.abs(prone - a_hi) < z.x[1] - z.x[0])


def test_the_model_layout_keeps_the_count_and_nests_under_refinement(coarse_analysis):
    """As many points as the hand layout; the density's ratios (r^2 : r : 1 with r = end_refinement)
    show as spacings; halving the pitch (rt.common.config.refined_sets) keeps every point."""
    cfg = with_sets(load(None, []), ["plant.interface.layout=model"])
    x = build_structure(cfg).x_pairs
    assert len(x) == len(HAND_DEFAULT_MM)
    assert x[0] == cfg.plant.interface.x_start_m and x[-1] == cfg.plant.interface.x_end_m
    d = np.diff(x)
    assert np.all(d > 0)
    r = cfg.plant.interface.end_refinement
    assert d.max() / d.min() == pytest.approx(r * r, rel=0.02)
    fine = build_structure(with_sets(cfg, refined_sets(cfg, 2))).x_pairs
    assert len(fine) == 2 * len(x) - 1
    np.testing.assert_allclose(fine[0::2], x, atol=1e-12)


def test_the_analysis_ignores_the_layouts_own_discretisation(coarse_analysis):
    """The zones are the joint's, not the layout's: the analysis configuration of the default and of
    its refined layout are the same (one analysis, cached)."""
    cfg = with_sets(load(None, []), ["plant.interface.layout=model"])
    a = coarse_analysis.analysis_config(cfg)
    b = coarse_analysis.analysis_config(with_sets(cfg, refined_sets(cfg, 2)))
    assert a == b
    assert dataclasses.replace(a.plant.interface).layout == "hand"
