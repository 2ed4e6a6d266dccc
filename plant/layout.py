"""The contact points placed from the preloaded joint's own figures (design time).

``plant.interface.layout = "model"`` keeps the hand layout's number of points (``hand_positions``:
``pitch_m`` with ``pitch_m / end_refinement`` over ``end_zone_m`` at both ends) and moves them to
where the joint's figures need them. Frictional contact converges at about first order in the
pitch, and the error comes from where the slip fronts lie between two points (Puso & Laursen
2004; Chouly & Hild 2013), so the points go where a slip front is, and as few as possible where
the beams stand apart.

The joint is analysed once on an interface sampled at ``ANALYSIS_INTERVALS`` equal intervals
(1.25 mm on the benchmark's 160 mm; elements twice that), independent of ``pitch_m``:

1. **Stuck pressure.** The static equilibrium under the screws at each of ``LEVELS`` forces F_N1
   spaced geometrically over [tracking.F_min_N, tracking.F_max_N] (plant.model.static_equilibrium)
   gives each point's normal force f_n and gap; a point is *closed* where g_n < 0 at some level.
2. **The range of the contact's inner edges.** Where the closed zone of a screw ends towards
   the open interface, the gap's zero crossing (linear between two points) is the edge; over the
   levels it sweeps [x_edge(F_max), x_edge(F_min)] (the adaptive screw's ~14 mm on the benchmark).
3. **Where slip starts.** With the closed points stuck (plant.model.stuck_stiffness), every stuck
   mode below ``impulse.f_max_hz`` loads point j tangentially by f_t,j = k_t,j (G_t phi)_j per
   unit modal amplitude; the ratio r_j = |f_t,j| / (mu f_n,j) says in which order the points reach
   their friction limit as the amplitude grows (Cattaneo-Mindlin: first where the pressure falls
   to zero and at the overlap's free end). A point is *slip-prone* where r_j >= ``SLIP_RATIO``
   max_j r_j for some mode and level: it slips before the amplitude is 1 / SLIP_RATIO times the
   amplitude at which that mode's slip starts, by this linear estimate.

The line density of points is then rho(x) = r^2 over the analysis intervals that touch a
slip-prone point or lie in an edge's range, r over the other intervals that touch a closed point
and 1 elsewhere (r = ``end_refinement``), and the N + 1 points (N the hand layout's intervals)
equidistribute it: x_i = Phi^-1(i / N), Phi the normalised integral of rho from x_start_m.
Halving ``pitch_m`` doubles N with the same rho, so the refined layout holds every point of the
coarse one and one more in each interval (at its density's midpoint): every spacing halves where
rho is constant.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import scipy.linalg as sla

ANALYSIS_INTERVALS = 128   # the analysis interface's equal intervals (elements: twice as long)
LEVELS = 6                 # F_N1 levels, geometric over [F_min, F_max]
SLIP_RATIO = 0.25          # slip-prone: r_j >= SLIP_RATIO max r (module docstring, 3)


@dataclasses.dataclass(frozen=True)
class JointZones:
    """The analysis of the preloaded joint (module docstring, 1-3), on the analysis points x [m]."""
    x: np.ndarray             # analysis points [m]
    levels_N: np.ndarray      # F_N1 levels [N]
    f_n: np.ndarray           # (levels, points) normal force of each closed point [N] (0 open)
    closed: np.ndarray        # (levels, points) g_n < 0
    edges: tuple              # (lo, hi) [m] ranges swept by the closed zones' inner edges
    ratio: np.ndarray         # (points,) largest normalised r_j over modes and levels [-]
    slip_prone: np.ndarray    # (points,) ratio >= SLIP_RATIO

    def density(self, r: float) -> np.ndarray:
        """Point density per analysis interval (module docstring): r^2, r or 1 [relative]."""
        x = self.x
        touch = lambda mask: mask[:-1] | mask[1:]   # noqa: E731
        rho = np.where(touch(self.closed.any(axis=0)), r, 1.0)
        fine = touch(self.slip_prone)
        for lo, hi in self.edges:
            fine |= (x[1:] > lo) & (x[:-1] < hi)
        return np.where(fine, r * r, rho)


def hand_positions(itf) -> np.ndarray:
    """The hand layout [m]: x_start .. x_end at pitch_m, each of the n_z pitches nearest either
    end (n_z = end_zone_m / pitch_m rounded up) split into end_refinement; where the two zones
    meet, every pitch is (plant.interface; validated to whole pitches)."""
    n = int(round((itf.x_end_m - itf.x_start_m) / itf.pitch_m))
    n_z = math.ceil(itf.end_zone_m / itf.pitch_m - 1e-6)
    x = itf.x_start_m + itf.pitch_m * np.arange(n + 1)
    r = itf.end_refinement
    inner = [x[k] + itf.pitch_m * j / r for k in range(n) if k < n_z or k >= n - n_z for j in range(1, r)]
    return np.sort(np.concatenate([x, inner]))


def _analysis_config(cfg):
    """``cfg`` with its interface at ANALYSIS_INTERVALS equal intervals, the hand layout, elements
    twice the interval: the only parts of ``cfg`` the zones depend on stay."""
    i = cfg.plant.interface
    h = (i.x_end_m - i.x_start_m) / ANALYSIS_INTERVALS
    itf = dataclasses.replace(i, pitch_m=h, end_refinement=1, layout="hand")
    return dataclasses.replace(cfg, plant=dataclasses.replace(cfg.plant, interface=itf, element_length_m=2.0 * h,
                                                              substeps=1))


def _edges(x: np.ndarray, g_n: np.ndarray) -> list[float]:
    """Inner edges [m] of the closed runs at one level: the zero crossings of g_n (linear between
    the two points around it) at the ends of each closed run that face an open point."""
    out = []
    for j in range(len(x) - 1):
        if (g_n[j] < 0.0) != (g_n[j + 1] < 0.0):
            out.append(x[j] + (x[j + 1] - x[j]) * g_n[j] / (g_n[j] - g_n[j + 1]))
    return out


@functools.lru_cache(maxsize=8)
def joint_zones(cfg) -> JointZones:
    """The preloaded joint's closed points, edge ranges and slip-prone points (module docstring)
    for ``cfg``'s structure, screws and contact law (its own layout and discretisation unused)."""
    from frictionrt.plant.model import build_plant, contact_forces, static_equilibrium, stuck_stiffness

    a_cfg = _analysis_config(cfg)
    model = build_plant(a_cfg)
    p = model.params
    x = model.structure.x_pairs
    t = cfg.tracking
    has_adaptive = bool(np.any(p.b_N1 != 0.0))
    levels = (np.geomspace(max(t.F_min_N, 1e-3), t.F_max_N, LEVELS) if has_adaptive else np.zeros(1))
    f_n = np.zeros((len(levels), len(x)))
    closed = np.zeros((len(levels), len(x)), bool)
    ratio = np.zeros(len(x))
    crossings = []
    for k, F in enumerate(levels):
        q, w, g = static_equilibrium(model, float(F))
        lam, _, _ = contact_forces(model, g, np.zeros_like(w))
        closed[k] = g[0::2] < 0.0
        f_n[k] = np.where(closed[k], np.abs(lam[0::2]), 0.0)
        crossings.append(_edges(x, g[0::2]))
        lam_e, V = sla.eigh(stuck_stiffness(model, closed[k]),
                            subset_by_value=(-np.inf, (2.0 * np.pi * cfg.impulse.f_max_hz) ** 2))
        keep = np.sqrt(np.maximum(lam_e, 0.0)) / (2.0 * np.pi) > 1e-3   # no rigid-body modes
        ft = np.abs(p.k_t[:, None] * (p.G[1::2] @ V[:, keep]))
        floor = 1e-9 * f_n[k].max()   # a point closed by round-off: finite ratio, still the largest
        r = np.where(closed[k][:, None], ft / (p.mu[:, None] * np.maximum(f_n[k][:, None], floor)), 0.0)
        r_max = r.max(axis=0)
        ratio = np.maximum(ratio, (r / np.where(r_max > 0.0, r_max, 1.0)).max(axis=1))
    edges = _edge_ranges(crossings)
    return JointZones(x, levels, f_n, closed, edges, ratio, ratio >= SLIP_RATIO)


def _edge_ranges(crossings: list[list[float]]) -> tuple:
    """The crossings of every level matched by their order (a level's k-th edge is the k-th edge
    of another level while the number of closed runs does not change), as (lo, hi) ranges [m];
    where the number changes, each crossing is its own range of no length."""
    if len({len(c) for c in crossings}) == 1:
        c = np.array(crossings)
        return tuple((float(c[:, k].min()), float(c[:, k].max())) for k in range(c.shape[1]))
    return tuple((xe, xe) for c in crossings for xe in c)


def model_positions(cfg) -> np.ndarray:
    """The model layout [m] (module docstring): as many points as the hand layout of ``cfg``'s
    pitch_m, end_refinement and end_zone_m, equidistributing ``JointZones.density``."""
    itf = cfg.plant.interface
    n = len(hand_positions(itf)) - 1
    z = joint_zones(_analysis_config(cfg))
    rho = z.density(float(itf.end_refinement))
    phi = np.concatenate([[0.0], np.cumsum(rho * np.diff(z.x))])
    x = np.interp(phi[-1] * np.arange(n + 1) / n, phi, z.x)
    x[0], x[-1] = itf.x_start_m, itf.x_end_m
    return x
