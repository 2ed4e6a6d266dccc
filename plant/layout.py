"""The contact points placed from the preloaded joint's own figures (design time).

``plant.interface.layout = "model"`` keeps the hand layout's number of points (``hand_positions``:
``pitch_m`` with ``pitch_m / end_refinement`` over ``end_zone_m`` at both ends) and moves them to
where the joint's figures need them. Frictional contact converges at about first order in the
pitch, and the error comes from where the slip fronts lie between two points (Puso & Laursen
2004; Chouly & Hild 2013), so the points go where a slip front is, and as few as possible where
the beams stand apart.

The joint is analysed once on an interface sampled at ``ANALYSIS_INTERVALS`` equal intervals
(1.25 mm on the benchmark's 160 mm; elements twice that), independent of ``pitch_m``, on the full
(unreduced, sparse) stiffness and mass of the bolted beams (plant.structure):

1. **Stuck pressure.** The static state under the screws with every closed point stuck, at each
   of ``LEVELS`` forces F_N1 spaced geometrically over [tracking.F_min_N, tracking.F_max_N], the
   screws' springs referenced as plant.model references them (their preloads in the assembled
   state at actuator.F0_N), gives each point's normal force f_n and gap; a point is *closed* where
   g_n < 0 at some level.
2. **The range of the contact's inner edges.** Where the closed zone of a screw ends towards
   the open interface, the gap's zero crossing (linear between two points) is the edge; over the
   levels it sweeps [x_edge(F_max), x_edge(F_min)] (the adaptive screw's ~14 mm on the benchmark).
3. **Where slip starts.** With the closed points stuck, every stuck mode below ``impulse.f_max_hz`` loads point j tangentially by f_t,j = k_t,j (G_t phi)_j per
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

``plant.interface.layout = "fronts"`` (``fronts_positions``) keeps the hand layout's spacings where
the joint is closed and takes the points the hand layout spends on the open interface to the slip
fronts: with h = pitch_m, the density is r^2 / h over the intervals that touch a slip-prone point or
lie in an edge's range, r / h over the other intervals that touch a point closed at some level (the
hand layout's end spacing, over the whole closed contact), and over the open interface the uniform
density that makes the N intervals of the hand layout, at least 1 / (``OPEN_PITCHES_MAX`` h) (if
the closed contact and the fronts alone need more than N intervals, all densities scale down so
that the count stays N). It nests under halving like the model layout.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

ANALYSIS_INTERVALS = 128   # the analysis interface's equal intervals (elements: twice as long)
ANALYSIS_MODES = 24        # stuck modes computed per level (those below impulse.f_max_hz are used)
LEVELS = 6                 # F_N1 levels, geometric over [F_min, F_max]
SLIP_RATIO = 0.25          # slip-prone: r_j >= SLIP_RATIO max r (module docstring, 3)
OPEN_PITCHES_MAX = 4.0     # "fronts": the open interface's spacing at most this many pitch_m


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

    def zone_masks(self) -> tuple[np.ndarray, np.ndarray]:
        """(fine, closed) per analysis interval: it touches a slip-prone point or lies in an edge's
        range; it touches a point closed at some level (module docstring)."""
        x = self.x
        touch = lambda mask: mask[:-1] | mask[1:]   # noqa: E731
        fine = touch(self.slip_prone)
        for lo, hi in self.edges:
            fine |= (x[1:] > lo) & (x[:-1] < hi)
        return fine, touch(self.closed.any(axis=0))

    def density(self, r: float) -> np.ndarray:
        """Point density per analysis interval (module docstring): r^2, r or 1 [relative]."""
        fine, closed = self.zone_masks()
        return np.where(fine, r * r, np.where(closed, r, 1.0))


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


def analysis_config(cfg):
    """``cfg`` with its interface at ANALYSIS_INTERVALS equal intervals, the hand layout, elements
    twice the interval: the only parts of ``cfg`` the zones depend on stay."""
    i = cfg.plant.interface
    h = (i.x_end_m - i.x_start_m) / ANALYSIS_INTERVALS
    itf = dataclasses.replace(i, pitch_m=h, end_refinement=1, layout="hand")
    return dataclasses.replace(cfg, plant=dataclasses.replace(cfg.plant, interface=itf, element_length_m=2.0 * h,
                                                              substeps=1))


def _edges(x: np.ndarray, g_n: np.ndarray) -> list[float]:
    """Inner edges [m] of the closed runs at one level: the zero crossings of g_n (linear between
    the two points around it)."""
    out = []
    for j in range(len(x) - 1):
        if (g_n[j] < 0.0) != (g_n[j + 1] < 0.0):
            out.append(x[j] + (x[j + 1] - x[j]) * g_n[j] / (g_n[j] - g_n[j + 1]))
    return out


def _stuck_static(K, f: np.ndarray, G, k_n: np.ndarray, k_t: np.ndarray, max_iter: int = 50) -> np.ndarray:
    """q [m] of K q = f + G^T lambda with every closed pair stuck: lambda_n = -k_n g_n where g_n < 0,
    lambda_t = -k_t g_t there (the stuck pressure); the closed set iterated from all closed until it
    repeats. K, G sparse. RuntimeError if it does not settle."""
    closed = np.ones(len(k_n), bool)
    for _ in range(max_iter):
        q = spla.spsolve(_with_contact(K, G, k_n, k_t, closed), f)
        now = (G[0::2] @ q) < 0.0
        if np.array_equal(now, closed):
            return q
        closed = now
    raise RuntimeError("the stuck static state under the screws did not settle its closed pairs; check the "
                       "interface stiffnesses and screw positions")


def _with_contact(K, G, k_n: np.ndarray, k_t: np.ndarray, closed: np.ndarray):
    """K + G^T diag(k) G with k_n, k_t on the ``closed`` pairs (sparse, CSC)."""
    k = np.zeros(G.shape[0])
    k[0::2], k[1::2] = k_n * closed, k_t * closed
    return (K + G.T @ sp.diags(k) @ G).tocsc()


def joint_zones(st, cfg) -> JointZones:
    """The preloaded joint's closed points, edge ranges and slip-prone points (module docstring)
    from the structure ``st`` (plant.structure.Structure of ``analysis_config(cfg)``): physical
    stiffness and mass of the bolted beams, the screws' preloads with their springs referenced to
    the assembled state at actuator.F0_N, as plant.model builds them (docs/plant.md 1.4)."""
    t = cfg.tracking
    x = st.x_pairs
    G = sp.csr_matrix(np.where(np.abs(st.gap_rows) > 0.0, st.gap_rows, 0.0))
    K_free = sp.block_diag([sp.csr_matrix(sub.K) for sub in st.subs]).tocsc()
    M = sp.block_diag([sp.csr_matrix(sub.M) for sub in st.subs]).tocsc()
    K = (K_free + sp.csr_matrix(st.bolt_stiffness())).tocsc()
    # the bolts' reference: tightened to their preloads in the assembled state at F0 (no spring force there)
    q0 = _stuck_static(K_free, st.f_const + st.b_N1 * cfg.actuator.F0_N, G, st.k_n, st.k_t)
    f_ref = st.bolt_rows.T @ (st.bolt_k * (st.bolt_rows @ q0))
    levels = np.geomspace(max(t.F_min_N, 1e-3), t.F_max_N, LEVELS) if st.adaptive >= 0 else np.zeros(1)
    f_n = np.zeros((len(levels), len(x)))
    closed = np.zeros((len(levels), len(x)), bool)
    ratio = np.zeros(len(x))
    crossings = []
    w_max2 = (2.0 * np.pi * cfg.impulse.f_max_hz) ** 2
    for k, F in enumerate(levels):
        q = _stuck_static(K, st.f_const + st.b_N1 * F + f_ref, G, st.k_n, st.k_t)
        g_n = G[0::2] @ q
        closed[k] = g_n < 0.0
        f_n[k] = np.where(closed[k], -st.k_n * g_n, 0.0)
        crossings.append(_edges(x, g_n))
        lam_e, V = spla.eigsh(_with_contact(K, G, st.k_n, st.k_t, closed[k]), k=ANALYSIS_MODES, M=M, sigma=0.0)
        if lam_e.max() <= w_max2:
            raise RuntimeError(f"more than {ANALYSIS_MODES} stuck modes below impulse.f_max_hz = "
                               f"{cfg.impulse.f_max_hz:g} Hz: raise plant.layout.ANALYSIS_MODES")
        V = V[:, (lam_e > (2.0 * np.pi * 1e-3) ** 2) & (lam_e <= w_max2)]   # no rigid-body modes
        ft = np.abs(st.k_t[:, None] * (G[1::2] @ V))
        floor = 1e-9 * f_n[k].max()   # a point closed by round-off: finite ratio, still the largest
        r = np.where(closed[k][:, None], ft / (st.mu[:, None] * np.maximum(f_n[k][:, None], floor)), 0.0)
        r_max = r.max(axis=0)
        ratio = np.maximum(ratio, (r / np.where(r_max > 0.0, r_max, 1.0)).max(axis=1))
    return JointZones(x, levels, f_n, closed, _edge_ranges(crossings), ratio, ratio >= SLIP_RATIO)


def _edge_ranges(crossings: list[list[float]]) -> tuple:
    """The crossings of every level matched by their order (a level's k-th edge is the k-th edge
    of another level while the number of closed runs does not change), as (lo, hi) ranges [m];
    where the number changes, each crossing is its own range of no length."""
    if len({len(c) for c in crossings}) == 1:
        c = np.array(crossings)
        return tuple((float(c[:, k].min()), float(c[:, k].max())) for k in range(c.shape[1]))
    return tuple((xe, xe) for c in crossings for xe in c)


def model_positions(itf, zones: JointZones) -> np.ndarray:
    """The model layout [m] (module docstring): as many points as the hand layout of the interface
    ``itf``'s pitch_m, end_refinement and end_zone_m, equidistributing ``zones.density``."""
    n = len(hand_positions(itf)) - 1
    return _equidistribute(itf, zones.x, zones.density(float(itf.end_refinement)), n)


def fronts_positions(itf, zones: JointZones) -> np.ndarray:
    """The fronts layout [m] (module docstring): as many points as the hand layout of ``itf``,
    pitch_m / end_refinement over the closed contact, pitch_m / end_refinement^2 at the slip
    fronts and the rest spread evenly over the open interface."""
    n = len(hand_positions(itf)) - 1
    r, h = float(itf.end_refinement), itf.pitch_m
    fine, closed = zones.zone_masks()
    dx = np.diff(zones.x)
    rho = np.where(fine, r * r / h, np.where(closed, r / h, 0.0))
    open_ = ~(fine | closed)
    length_open = float(dx[open_].sum())
    if length_open > 0.0:
        rho[open_] = max((n - float((rho * dx).sum())) / length_open, 1.0 / (OPEN_PITCHES_MAX * h))
    return _equidistribute(itf, zones.x, rho, n)


def _equidistribute(itf, x: np.ndarray, rho: np.ndarray, n: int) -> np.ndarray:
    """n + 1 points x_i = Phi^-1(i / n) of the density rho per interval of x, the ends pinned."""
    phi = np.concatenate([[0.0], np.cumsum(rho * np.diff(x))])
    out = np.interp(phi[-1] * np.arange(n + 1) / n, phi, x)
    out[0], out[-1] = itf.x_start_m, itf.x_end_m
    return out
