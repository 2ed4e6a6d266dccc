"""The interface of an imported structure coarsened along the bolts' contact footprints.

A node-clustering hyper-reduction (plant.superelement.coarsen) replaces a group of contact points by
one point acting on the group's mean gaps. A group that mixes points the bolts close with points
they leave open has a mean gap that may stay open: the closed patch is lost. Here the points are
classed by the static contact state of the interface as read, at the adaptive bolt's forces of the
configuration (``footprint_levels_n``): class i holds the points that close at the i-th force and not
below it. The coarsening keeps classes and their connected regions apart and spends its groups on
the class closed at the smallest force first (``coarsen_structure``, docs/superelement.md section 3).

A group acts on its area-weighted mean gaps, so it keeps its points' common motion and loses the
rest: on a patch the bolts hold closed, the penalty's resistance to the points' gaps differing from
the mean (the patch's rocking and its local bending against the other body), which at F_min is most
of the closed patch's stiffness in bending. With clustering "footprint-patches" that part is kept
as a constant stiffness (``patch_stiffness``) for the groups whose every point is closed at the
smallest force of ``footprint_levels_n`` (footprint class 0: what the bolts hold closed over the
whole tracking range, but for the few edge points that a larger force lifts). Per group of points i with normal rows r_i, areas a_i, mean
r = sum a_i r_i / A, the normal penalty's energy splits exactly while every point is closed
(k_n'' the configuration's k_n_area):

    sum_i k_n'' a_i (r_i q + g0_i)^2 / 2 = k_n'' A (r q + g0)^2 / 2                  (the coarse point)
                                        + sum_i k_n'' a_i ((r_i - r) q + g0_i - g0)^2 / 2   (kept: dK, df)

(the cross term vanishes: sum_i a_i (r_i - r) = 0). The tangential rows are not split: a group that
slips slips as a whole, as before.
"""
from __future__ import annotations

import numpy as np

from frictionrt.plant.se_plant import build_se_plant, static_equilibrium
from frictionrt.plant.superelement import (CLUSTERINGS, DEFAULT_CLUSTERING, Superelement, SuperelementError, coarsen,
                                          check, coarsen_weights)


def footprint_levels_n(cfg) -> tuple[float, ...]:
    """The adaptive bolt's forces [N] at which ``footprint_classes`` takes the contact state: the
    tracking range's ends (tracking.F_min_N, F_max_N), the rest force actuator.F0_N and the adaptive
    screw's preload F_N, sorted and distinct."""
    from frictionrt.rt.common.config import adaptive_screw
    screw = adaptive_screw(cfg)
    lv = {cfg.tracking.F_min_N, cfg.tracking.F_max_N, cfg.actuator.F0_N} | ({screw.F_N} if screw is not None else set())
    return tuple(sorted(float(f) for f in lv))


def footprint_closed(se: Superelement, cfg) -> np.ndarray:
    """(levels, p) bool: point i of se (as read) closed (g_n < 0) in the static equilibrium with the
    ordinary bolts' preload and the adaptive bolt pressing with the force F_l of
    ``footprint_levels_n(cfg)`` (its spring removed: the bolt is a force here; cfg's interface law).
    RuntimeError (one line) if the interface has no static equilibrium at one of them."""
    levels = footprint_levels_n(cfg)
    params = build_se_plant(se.with_(adaptive_k=0.0), cfg, F_N1=levels[0]).params
    d = 1 + params.nt
    out = np.zeros((len(levels), se.n_points), bool)
    for i in range(len(levels) - 1, -1, -1):
        _, _, g = static_equilibrium(params, levels[i])
        out[i] = g[0::d] < 0.0
    return out


def classes_of(closed: np.ndarray) -> np.ndarray:
    """``footprint_classes`` from ``footprint_closed``'s (levels, p) array: per point the first level
    that closes it, len(levels) if none does."""
    return np.where(closed.any(axis=0), np.argmax(closed, axis=0), closed.shape[0]).astype(np.int64)


def footprint_classes(se: Superelement, cfg) -> np.ndarray:
    """Per contact point of se (as read) the index i of the smallest force F_i of
    ``footprint_levels_n(cfg)`` at which the point is closed (g_n < 0) in the static equilibrium
    with the ordinary bolts' preload and the adaptive bolt pressing with F_i (its spring removed:
    the bolt is a force here; cfg's interface law); len(levels) if it is open at every F_i.
    Class 0 is what the bolts close at the smallest force: on the paper's structure the patch under
    the ordinary bolt and the damper's end beyond the adaptive one. RuntimeError (one line) if the
    interface has no static equilibrium."""
    return classes_of(footprint_closed(se, cfg))


def patch_stiffness(se: Superelement, W: np.ndarray, held: np.ndarray, k_n_area: float):
    """(dK (n, n) [N/m per unit q^2], df (n,) [N]): the normal penalty's part that a coarse point
    loses, for each group of W (``coarsen_weights``, (c, p)) whose points are all ``held`` (bool,
    (p,): closed at every force of the operating range): sum_i k_n_area a_i d_i^T d_i with
    d_i = r_i - r the deviation of point i's normal row from its group's area-weighted mean
    (module docstring), and the force of the initial gaps' deviations, -sum_i k_n_area a_i d_i^T
    (g0_i - g0). Exact while every point of such a group stays closed; a group that opens keeps it."""
    n = se.n
    dK = np.zeros((n, n))
    df = np.zeros(n)
    R = se.contact_rows[:, 0, :]
    a = se.contact_area
    for w in W:
        g = np.flatnonzero(w)
        if len(g) < 2 or not held[g].all():
            continue
        D = R[g] - w[g] @ R[g]
        dK += (D.T * (k_n_area * a[g])) @ D
        if se.contact_gap0 is not None:
            e = se.contact_gap0[g] - w[g] @ se.contact_gap0[g]
            df -= D.T @ (k_n_area * a[g] * e)
    return 0.5 * (dK + dK.T), df


def coarsen_structure(se: Superelement, n_clusters: int, cfg, clustering: str = DEFAULT_CLUSTERING,
                      closed: np.ndarray | None = None) -> Superelement:
    """se's interface coarsened to n_clusters points (plant.superelement.coarsen) by ``clustering``
    (plant.superelement.CLUSTERINGS): "footprint" within the bolts' contact footprints under cfg
    (``footprint_classes``), "footprint-patches" the same groups with the held patches' normal
    stiffness kept in K (``patch_stiffness``; the groups of class 0, closed at the smallest force of
    ``footprint_levels_n``), "coordinates" by k-means on the coordinates alone. closed: the
    ``footprint_closed`` array if already solved. n_clusters 0 (or the interface's own count): se
    as read. SuperelementError (one line) for an unknown clustering or a count out of range;
    RuntimeError (one line) if the interface as read has no static equilibrium."""
    if clustering not in CLUSTERINGS:
        raise SuperelementError(f"clustering: {clustering!r} is not one of {', '.join(CLUSTERINGS)}")
    if not n_clusters or n_clusters == se.n_points:
        return se
    if clustering == "coordinates" or not 1 <= n_clusters <= se.n_points or se.contact_xyz is None:
        return coarsen(se, n_clusters)      # the grouping, or its one-line error
    if closed is None:
        closed = footprint_closed(se, cfg)
    classes = classes_of(closed)
    out = coarsen(se, n_clusters, classes=classes)
    if clustering != "footprint-patches":
        return out
    W = coarsen_weights(se, n_clusters, classes=classes)
    dK, df = patch_stiffness(se, W, closed[0], cfg.plant.interface.k_n_area)
    held = sum(1 for w in W if len(np.flatnonzero(w)) > 1 and closed[0][np.flatnonzero(w)].all())
    f_bolts = df if se.f_bolts is None else se.f_bolts + df
    return check(out.with_(K=out.K + dK, f_bolts=f_bolts,
                           source=f"{out.source}, the {held} held groups' patch stiffness kept"))
