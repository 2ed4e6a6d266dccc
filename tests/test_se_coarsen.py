"""Coarsening an imported interface along the bolts' contact footprints (plant.superelement.coarsen
with classes, plant.se_coarsen): the grouping on a toy grid, and on the small 3-D reference (39
points) the closed patch at the adaptive bolt kept closed and the closed-stuck frequencies kept."""
from __future__ import annotations

import numpy as np
import pytest

from frictionrt.plant import superelement as S


def _grid_se(nx: int = 8, ny: int = 3) -> S.Superelement:
    """nx x ny points 10 mm apart; point i's gap rows are the unit vector e_i, so a coarse point's
    rows name its members (the area-weighted mean of the members' rows)."""
    p = nx * ny
    xyz = np.column_stack([np.repeat(np.arange(nx) * 0.01, ny), np.tile(np.arange(ny) * 0.01, nx), np.zeros(p)])
    rows = np.zeros((p, 3, p))
    rows[np.arange(p), 0, np.arange(p)] = 1.0
    return S.Superelement(M=np.eye(p), K=np.eye(p), contact_rows=rows, contact_area=np.full(p, 1e-4),
                          contact_xyz=xyz)


def _members(c: S.Superelement) -> list[np.ndarray]:
    return [np.flatnonzero(r) for r in c.contact_rows[:, 0, :]]


def test_footprint_groups_never_mix_classes_or_regions_and_refine_class_0_first():
    """Classes on an 8 x 3 grid: class 0 at both ends (x = 0 and x = 70 mm: two regions of 3 points),
    class 1 the next column in (two regions), class 2 the 12 points between. With 10 groups for the
    5 regions, the remaining 5 go to class 0 first (its 6 points become 6 groups: every class-0 point
    its own), then 1 to class 1; no group mixes classes or regions. With 4 groups (fewer than twice
    the 5 regions) classes 1 and 2 merge: 3 regions (the two class-0 ends and the middle), and no
    group mixes class 0 with the rest."""
    se = _grid_se()
    col = np.repeat(np.arange(8), 3)
    cls = np.where((col == 0) | (col == 7), 0, np.where((col == 1) | (col == 6), 1, 2))
    region = S.footprint_regions(se.contact_xyz, cls)
    assert region.max() + 1 == 5
    c = S.coarsen(se, 10, classes=cls)
    groups = _members(c)
    assert c.n_points == 10 and sorted(np.concatenate(groups).tolist()) == list(range(24))
    for g in groups:
        assert len(set(cls[g])) == 1 and len(set(region[g])) == 1
    assert sum(1 for g in groups if cls[g[0]] == 0) == 6
    assert sum(1 for g in groups if cls[g[0]] == 1) == 3
    c4 = S.coarsen(se, 4, classes=cls)
    for g in _members(c4):
        assert len(set(cls[g] == 0)) == 1 and (cls[g[0]] != 0 or len(set(col[g] == 0)) == 1)
    assert sum(1 for g in _members(c4) if cls[g[0]] == 0) >= 2


@pytest.fixture(scope="module")
def small_reference():
    pytest.importorskip("skfem")
    from frictionrt.plant import fe3d
    from frictionrt.rt.common.config import Config
    cfg = Config()
    se, _ = fe3d.reference_superelement(cfg, interface_pitch_m=0.04, pitch_m=0.05, cutoff_hz=4000.0)
    return cfg, se


def test_footprint_clustering_keeps_the_adaptive_patch_closed(small_reference):
    """The small 3-D reference (39 points): at F_min = 40 N the bolts close the patch under the
    ordinary bolt and the damper's end beyond the adaptive one (footprint class 0 on both sides).
    Coarsened to 8 points by footprint, a point on the adaptive side (x > 0.6 m) stays closed, and
    the lowest 8 closed-stuck frequencies lie within 1 % of the 39 points' (measured -0.68..-0.01 %;
    the coarse groups lose only the patches' own rotation stiffness, so they err low). The
    k-means grouping of the same 8 points closed none on that side in this build (its mode 4:
    -5.95 %; docs/studies/superelement-3d.md), which is what the footprint grouping fixes."""
    from frictionrt.plant.se_analysis import modes_summary
    from frictionrt.plant.se_coarsen import coarsen_structure, footprint_classes
    from frictionrt.plant.se_plant import build_se_plant
    cfg, se = small_reference
    F = cfg.tracking.F_min_N
    cls = footprint_classes(se, cfg)
    x = se.contact_xyz[:, 0]
    assert np.any((cls == 0) & (x < 0.5)) and np.any((cls == 0) & (x > 0.6))
    c = coarsen_structure(se, 8, cfg)
    plant = build_se_plant(c, cfg, F_N1=F)
    g = plant.initial_state(F)[plant.state_slots()["g"]][0::3]
    assert np.any((g < 0) & (c.contact_xyz[:, 0] > 0.6))
    ref = np.array(modes_summary(build_se_plant(se, cfg, F_N1=F), F)["stuck_closed_hz"])
    got = np.array(modes_summary(plant, F)["stuck_closed_hz"])
    np.testing.assert_allclose(got, ref, rtol=0.01)
    assert coarsen_structure(se, 8, cfg, "coordinates").source.endswith("coarsened to 8 points")
    with pytest.raises(S.SuperelementError, match="clustering: 'pressure' is not one of footprint, coordinates"):
        coarsen_structure(se, 8, cfg, "pressure")


def test_footprint_patches_keep_the_held_patches_stiffness(small_reference):
    """The small 3-D reference (39 points) coarsened to 6 footprint points with the held patches'
    normal stiffness kept (clustering "footprint-patches", plant.se_coarsen.patch_stiffness): the
    lowest 8 closed-stuck frequencies at F_min within 0.5 % of the 39 points' (measured
    -0.40..0.00 %; the plain footprint groups -0.98..-0.01 %), the same points closed; the kept
    stiffness is the held groups' only, so with no point held (an empty class 0) the coarse
    structure's K is the plain footprint coarsening's."""
    from frictionrt.plant.se_analysis import modes_summary
    from frictionrt.plant.se_coarsen import coarsen_structure, footprint_closed
    from frictionrt.plant.se_plant import build_se_plant
    cfg, se = small_reference
    F = cfg.tracking.F_min_N
    closed = footprint_closed(se, cfg)
    ref = modes_summary(build_se_plant(se, cfg, F_N1=F), F)
    c = coarsen_structure(se, 6, cfg, "footprint-patches", closed=closed)
    got = modes_summary(build_se_plant(c, cfg, F_N1=F), F)
    np.testing.assert_allclose(got["stuck_closed_hz"], ref["stuck_closed_hz"], rtol=0.005)
    assert got["closed_points"] == 5 and c.source.endswith("held groups' patch stiffness kept")
    none_held = closed.copy()
    none_held[0] = False
    plain = coarsen_structure(se, 6, cfg, "footprint", closed=closed)
    assert np.array_equal(coarsen_structure(se, 6, cfg, "footprint-patches", closed=none_held).K, plain.K)
