"""The held patches' normal stiffness kept by a coarsened interface (plant.se_coarsen.patch_stiffness,
clustering "footprint-patches"): the energy split is exact on a toy, and on the small 3-D reference
the coarse interface's closed-stuck modes come back to the fine interface's."""
from __future__ import annotations

import numpy as np
import pytest

from frictionrt.plant import superelement as S


def test_patch_stiffness_restores_the_fine_normal_stiffness_of_held_groups():
    """A 6 x 2 grid of points with random rows (n = 5 coordinates) and initial gaps, grouped in 4 by
    the footprint rule (class 0 the first two columns, class 1 the rest). With every point held, the
    coarse points' normal stiffness plus dK is the fine points' sum_i k a_i r_i^T r_i and the coarse
    load plus df the fine -sum_i k a_i r_i^T g0_i (the energy split of plant.se_coarsen, both
    computed here from the fine rows); with only class 0 held, dK is the class-0 groups' part alone."""
    from frictionrt.plant.se_coarsen import patch_stiffness
    rng = np.random.default_rng(3)
    nx, ny, n = 6, 2, 5
    p = nx * ny
    xyz = np.column_stack([np.repeat(np.arange(nx) * 0.01, ny), np.tile(np.arange(ny) * 0.01, nx), np.zeros(p)])
    rows = rng.standard_normal((p, 3, n))
    area = rng.uniform(1e-5, 3e-5, p)
    gap0 = rng.uniform(-1e-6, 1e-6, p)
    se = S.Superelement(M=np.eye(n), K=np.eye(n), contact_rows=rows, contact_area=area, contact_xyz=xyz,
                        contact_gap0=gap0)
    cls = np.where(xyz[:, 0] < 0.015, 0, 1)
    W = S.coarsen_weights(se, 4, classes=cls)
    c = S.coarsen(se, 4, classes=cls)
    k = 2.5e12
    R = rows[:, 0, :]
    dK, df = patch_stiffness(se, W, np.ones(p, bool), k)
    Rc = c.contact_rows[:, 0, :]
    np.testing.assert_allclose((Rc.T * (k * c.contact_area)) @ Rc + dK, (R.T * (k * area)) @ R, rtol=1e-12, atol=0)
    np.testing.assert_allclose(-Rc.T @ (k * c.contact_area * c.contact_gap0) + df, -R.T @ (k * area * gap0),
                               rtol=1e-9, atol=1e-9 * np.abs(R.T @ (k * area * gap0)).max())
    dK0, _ = patch_stiffness(se, W, cls == 0, k)
    want = np.zeros((n, n))
    for w in W:
        g = np.flatnonzero(w)
        if cls[g[0]] == 0:
            D = R[g] - w[g] @ R[g]
            want += (D.T * (k * area[g])) @ D
    assert np.abs(want).max() > 0
    np.testing.assert_allclose(dK0, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
