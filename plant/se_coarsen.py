"""The interface of an imported structure coarsened along the bolts' contact footprints.

A node-clustering hyper-reduction (plant.superelement.coarsen) replaces a group of contact points by
one point acting on the group's mean gaps. A group that mixes points the bolts close with points
they leave open has a mean gap that may stay open: the closed patch is lost. Here the points are
classed by the static contact state of the interface as read, at the adaptive bolt's forces of the
configuration (``footprint_levels_n``): class i holds the points that close at the i-th force and not
below it. The coarsening keeps classes and their connected regions apart and spends its groups on
the class closed at the smallest force first (``coarsen_structure``, docs/superelement.md section 3).
"""
from __future__ import annotations

import numpy as np

from frictionrt.plant.se_plant import build_se_plant, static_equilibrium
from frictionrt.plant.superelement import CLUSTERINGS, DEFAULT_CLUSTERING, Superelement, SuperelementError, coarsen


def footprint_levels_n(cfg) -> tuple[float, ...]:
    """The adaptive bolt's forces [N] at which ``footprint_classes`` takes the contact state: the
    tracking range's ends (tracking.F_min_N, F_max_N), the rest force actuator.F0_N and the adaptive
    screw's preload F_N, sorted and distinct."""
    from frictionrt.rt.common.config import adaptive_screw
    screw = adaptive_screw(cfg)
    lv = {cfg.tracking.F_min_N, cfg.tracking.F_max_N, cfg.actuator.F0_N} | ({screw.F_N} if screw is not None else set())
    return tuple(sorted(float(f) for f in lv))


def footprint_classes(se: Superelement, cfg) -> np.ndarray:
    """Per contact point of se (as read) the index i of the smallest force F_i of
    ``footprint_levels_n(cfg)`` at which the point is closed (g_n < 0) in the static equilibrium
    with the ordinary bolts' preload and the adaptive bolt pressing with F_i (its spring removed:
    the bolt is a force here; cfg's interface law); len(levels) if it is open at every F_i.
    Class 0 is what the bolts close at the smallest force: on the paper's structure the patch under
    the ordinary bolt and the damper's end beyond the adaptive one. RuntimeError (one line) if the
    interface has no static equilibrium."""
    levels = footprint_levels_n(cfg)
    params = build_se_plant(se.with_(adaptive_k=0.0), cfg, F_N1=levels[0]).params
    d = 1 + params.nt
    out = np.full(se.n_points, len(levels), np.int64)
    for i in range(len(levels) - 1, -1, -1):
        _, _, g = static_equilibrium(params, levels[i])
        out[g[0::d] < 0.0] = i
    return out


def coarsen_structure(se: Superelement, n_clusters: int, cfg, clustering: str = DEFAULT_CLUSTERING) -> Superelement:
    """se's interface coarsened to n_clusters points (plant.superelement.coarsen) by ``clustering``
    (plant.superelement.CLUSTERINGS): "footprint" within the bolts' contact footprints under cfg
    (``footprint_classes``), "coordinates" by k-means on the coordinates alone. n_clusters 0 (or the
    interface's own count): se as read. SuperelementError (one line) for an unknown clustering or a
    count out of range; RuntimeError (one line) if the interface as read has no static equilibrium."""
    if clustering not in CLUSTERINGS:
        raise SuperelementError(f"clustering: {clustering!r} is not one of {', '.join(CLUSTERINGS)}")
    if not n_clusters or n_clusters == se.n_points:
        return se
    if clustering == "coordinates" or not 1 <= n_clusters <= se.n_points or se.contact_xyz is None:
        return coarsen(se, n_clusters)      # the grouping, or its one-line error
    return coarsen(se, n_clusters, classes=footprint_classes(se, cfg))
