"""The beam assembly described by the configuration: meshes, DOF maps, interface kinematics.

Everything that depends on *which* structure is simulated is derived here from
``Config.plant``; nothing downstream knows about the benchmark's dimensions. A different
assembly (a lap joint, a damper elsewhere) is a different TOML file.

Physical coordinates are the free DOFs of all beams stacked beam by beam
(3 per node: u, w, theta; clamped nodes removed).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from frictionrt.plant.bolts import cone_radius, pressure_weights, vdi_cone_tan
from frictionrt.plant.fe_beam import DOFS_PER_NODE, THETA, U, W, assemble_beam, frame_shape, mesh_nodes
from frictionrt.plant.layout import (JointZones, analysis_config, fronts_positions, hand_positions, joint_zones,
                                    model_positions)
from frictionrt.plant.tributary import tributary_lengths
from frictionrt.rt.common.config import Beam, Config, adaptive_screw


@dataclass(frozen=True)
class Substructure:
    """One beam: its mesh, free-DOF matrices and the DOFs kept as Craig-Bampton boundary."""
    beam: Beam
    x_nodes: np.ndarray        # [m]
    free: np.ndarray           # indices of free DOFs in the beam's 3*n_nodes vector
    K: np.ndarray              # on free DOFs [SI]
    M: np.ndarray
    boundary: np.ndarray       # indices into the free DOFs
    offset: int                # first index of this beam in the stacked physical vector

    def dof(self, x: float, component: int) -> int:
        """Stacked physical index of DOF `component` (U, W, THETA) at the node at x [m]."""
        node = int(np.argmin(np.abs(self.x_nodes - x)))
        if abs(self.x_nodes[node] - x) > 1e-9:
            raise ValueError(f"no node of beam {self.beam.name!r} at x = {x} m")
        hit = np.nonzero(self.free == DOFS_PER_NODE * node + component)[0]
        if len(hit) == 0:
            raise ValueError(f"DOF {component} of beam {self.beam.name!r} at x = {x} m is clamped")
        return self.offset + int(hit[0])

    def field_row(self, x: float, component: int) -> np.ndarray:
        """Row on the stacked physical vector (length ``offset + n`` is enough: the caller pads)
        giving the field ``component`` (U, W, THETA) at x [m]: the node's DOF at a node, else the
        element's interpolation (plant.fe_beam.frame_shape); clamped DOFs carry nothing."""
        if on_node(self.x_nodes, x):
            weights = {DOFS_PER_NODE * int(np.argmin(np.abs(self.x_nodes - x))) + component: 1.0}
        else:
            e = element_of(self.x_nodes, x)
            l = self.x_nodes[e + 1] - self.x_nodes[e]
            shape = frame_shape((x - self.x_nodes[e]) / l, l)[component]
            weights = {DOFS_PER_NODE * e + k: shape[k] for k in range(2 * DOFS_PER_NODE)}
        row = np.zeros(self.offset + self.n)
        for d, wt in weights.items():
            hit = np.nonzero(self.free == d)[0]
            if len(hit):
                row[self.offset + int(hit[0])] += wt
        return row

    @property
    def n(self) -> int:
        return len(self.free)


@dataclass(frozen=True)
class Structure:
    """The assembled description: substructures, contact pairs and load/output rows.

    Rows act on the stacked physical vector x (length n_dof):
      gap_rows[2j]   = normal gap g_n of pair j (upper minus lower; > 0 open) [m]
      gap_rows[2j+1] = tangential gap g_t of pair j (bottom of upper minus top of lower) [m]
      point_rows[i]  = transverse displacement w at point i [m]
      u_rel_row      = tangential relative displacement at the adaptive screw [m]
    Load vectors give nodal forces for a unit input [N]:
      b_exc  (excitation force, +z), b_N1 (adaptive screw force), f_const (the other screws).
    Bolts (one per screw, config order; docs/plant.md 1.4): bolt_rows[b] the normal gap at the
    screw (the beams' separation under it, > 0 open) [m], bolt_k[b] its axial stiffness [N/m]
    (ordinary bolt: the screw's stiffness_N_m; adaptive screw: k_stack, k_screw in series),
    bolt_F[b] its preload [N] (the adaptive screw's comes from the actuator: 0 here),
    bolt_names[b] the screw names, adaptive the index of the adaptive screw.
    Contact per unit area (SPEC 2): pair_area[j] is the interface area pair j stands for [m^2]
    (tributary length x the narrower beam's width: the pitch inside, half of it at both ends;
    plant/tributary.py), and k_n, k_t [N/m] are plant.interface.k_n_area, k_t_area times it.

    Without an adaptive screw (ordinary bolts only, or no interface at all: docs/plant.md 5.3)
    adaptive is -1 and b_N1, u_rel_row are zero (F_N1 then acts on nothing, u_rel reads 0),
    F_N1_initial is 0; without an interface there are no pairs (gap_rows (0, n_dof)) and no bolts.
    The kernels see the same array shapes and types, so they run unchanged.
    """
    subs: tuple[Substructure, ...]
    x_pairs: np.ndarray
    gap_rows: np.ndarray
    point_names: tuple[str, ...]
    point_rows: np.ndarray
    u_rel_row: np.ndarray
    b_exc: np.ndarray
    b_N1: np.ndarray
    f_const: np.ndarray
    F_N1_initial: float
    pair_area: np.ndarray
    k_n: np.ndarray
    k_t: np.ndarray
    mu: np.ndarray
    bolt_rows: np.ndarray
    bolt_k: np.ndarray
    bolt_F: np.ndarray
    bolt_names: tuple[str, ...]
    adaptive: int

    def bolt_stiffness(self) -> np.ndarray:
        """The bolts' springs on the stacked physical vector: sum_b k_b r_b r_b^T [N/m]."""
        return (self.bolt_rows.T * self.bolt_k) @ self.bolt_rows

    @property
    def n_pairs(self) -> int:
        return len(self.x_pairs)


def on_node(x_nodes: np.ndarray, x: float) -> bool:
    """True if a mesh node lies at x [m] (to 1 nm)."""
    return bool(np.min(np.abs(x_nodes - x)) <= 1e-9)


def element_of(x_nodes: np.ndarray, x: float) -> int:
    """Index e of the element [x_nodes[e], x_nodes[e + 1]] that holds x [m]."""
    return int(np.clip(np.searchsorted(x_nodes, x, side="right") - 1, 0, len(x_nodes) - 2))


def _pair_positions(cfg: Config) -> np.ndarray:
    """Contact point positions [m] by plant.interface.layout (plant/layout.py): "hand", x_start ..
    x_end at pitch_m with the n_z pitches nearest either end split into end_refinement
    (``hand_positions``); "model", as many points placed by the preloaded joint's stuck pressure
    and slip onset (``model_positions``); "fronts", as many points, the hand layout's end spacing over
    the closed contact and the open interface's points moved to the slip fronts (``fronts_positions``)."""
    i = cfg.plant.interface
    if not i.enabled:
        return np.zeros(0)
    if i.layout == "model":
        return model_positions(i, _joint_zones(analysis_config(cfg)))
    if i.layout == "fronts":
        return fronts_positions(i, _joint_zones(analysis_config(cfg)))
    return hand_positions(i)


@functools.lru_cache(maxsize=8)
def _joint_zones(a_cfg: Config) -> JointZones:
    """plant.layout.joint_zones of the analysis configuration ``a_cfg`` (one per structure and
    contact law: the layout's own pitch and its refinements share it)."""
    return joint_zones(build_structure(a_cfg), a_cfg)


def node_pairs(x_pairs: np.ndarray, h_min: float) -> np.ndarray:
    """The contact points that are also mesh nodes [m]: from the first, each point at least h_min
    [m] from the previous node, and the last. With a pitch >= the element length every point is a
    node (contact node-to-node); with a finer pitch the points between them sample the elements'
    interpolation (interface_rows)."""
    if len(x_pairs) == 0:
        return x_pairs
    keep = [x_pairs[0]]
    for x in x_pairs[1:-1]:
        if x - keep[-1] >= h_min - 1e-9:
            keep.append(x)
    if len(x_pairs) > 1:
        keep.append(x_pairs[-1])
    return np.array(keep)


def add_lumped(K: np.ndarray, M: np.ndarray, node_of, masses, rot_springs, w_springs=()) -> None:
    """Add lumped masses m [kg] at x (transverse and axial DOFs; rotary inertia neglected),
    rotational springs k = 1 / compliance [N m/rad] at x (compliance 0: none, the clamp fixes
    the rotation instead) and transverse springs to the ground k [N/m] at x (``w_springs``, (x, k);
    k 0: none) to a beam's assembled K, M in place."""
    for x, m in masses:
        for c in (U, W):
            M[DOFS_PER_NODE * node_of(x) + c, DOFS_PER_NODE * node_of(x) + c] += m
    for x, compliance in rot_springs:
        if compliance > 0:
            K[DOFS_PER_NODE * node_of(x) + THETA, DOFS_PER_NODE * node_of(x) + THETA] += 1.0 / compliance
    for x, k in w_springs:
        if k > 0:
            K[DOFS_PER_NODE * node_of(x) + W, DOFS_PER_NODE * node_of(x) + W] += k


@functools.lru_cache(maxsize=8)
def beam_matrices(x_nodes: tuple[float, ...], E: float, width: float, height: float, rho: float,
                  masses: tuple, rot_springs: tuple, w_springs: tuple, free: tuple[int, ...]
                  ) -> tuple[np.ndarray, np.ndarray]:
    """K, M of one beam meshed at ``x_nodes`` [m] (``assemble_beam``) with its lumped masses and
    springs (``add_lumped``: (x, m), (x, compliance), (x, k) tuples) on its free DOFs ``free``
    (indices into the 3 per node). Read-only and cached by these arguments: a design that changes
    other parameters (the contact's, the damping: a fit's Jacobian columns) gets the same arrays,
    and ``plant.model.build_plant`` then reuses their reduction."""
    x = np.array(x_nodes)
    K, M = assemble_beam(x, E, width, height, rho)
    add_lumped(K, M, lambda xq: int(np.argmin(np.abs(x - xq))), masses, rot_springs, w_springs)
    f = np.array(free, dtype=np.int64)
    K, M = K[np.ix_(f, f)], M[np.ix_(f, f)]
    K.setflags(write=False)
    M.setflags(write=False)
    return K, M


def build_structure(cfg: Config) -> Structure:
    """Mesh every beam, assemble its K and M, and build the interface kinematics."""
    p = cfg.plant
    itf = p.interface
    x_pairs = _pair_positions(cfg)
    screws = p.screws

    subs: list[Substructure] = []
    offset = 0
    for b in p.beams:
        in_itf = itf.enabled and b.name in (itf.lower, itf.upper)
        full_nodes = list(node_pairs(x_pairs, p.element_length_m)) + [s.x_m for s in screws] if in_itf else []
        w_nodes = [pt.x_m for pt in p.points if pt.beam == b.name]
        clamp_x = [c.x_m for c in p.clamps if c.beam == b.name]
        x_nodes = mesh_nodes(b.x0_m, b.x0_m + b.length_m, full_nodes + w_nodes + clamp_x, p.element_length_m)
        if in_itf:  # a pair between nodes moves with its element's two nodes: they are boundary too
            between = [element_of(x_nodes, x) for x in x_pairs if not on_node(x_nodes, x)]
            full_nodes += [float(x_nodes[e + k]) for e in between for k in (0, 1)]

        def node_of(x):
            return int(np.argmin(np.abs(x_nodes - x)))

        fixed = {DOFS_PER_NODE * node_of(c.x_m) + d for c in p.clamps if c.beam == b.name
                 for d in (U,) + ((W,) if c.trans_compliance_m_per_N == 0 else ())
                 + ((THETA,) if c.rot_compliance_rad_per_Nm == 0 else ())}
        free = np.array([d for d in range(DOFS_PER_NODE * len(x_nodes)) if d not in fixed], dtype=np.int64)
        K, M = beam_matrices(
            tuple(x_nodes.tolist()), b.E, b.width_m, b.height_m, b.rho,
            tuple([(pt.x_m, pt.mass_kg) for pt in p.points if pt.beam == b.name]
                  + [(s.x_m, s.mass_kg + (cfg.actuator.moving_mass_kg if s.adaptive else 0.0))
                     for s in screws if in_itf and b.name == itf.upper]),
            tuple((c.x_m, c.rot_compliance_rad_per_Nm) for c in p.clamps if c.beam == b.name),
            tuple([(c.x_m, 1.0 / c.trans_compliance_m_per_N) for c in p.clamps
                   if c.beam == b.name and c.trans_compliance_m_per_N > 0]
                  + [(pt.x_m, pt.stiffness_N_m) for pt in p.points if pt.beam == b.name]),
            tuple(free.tolist()))
        pos = {d: k for k, d in enumerate(free)}
        bset = {DOFS_PER_NODE * node_of(x) + c for x in full_nodes for c in (U, W, THETA)}
        bset |= {DOFS_PER_NODE * node_of(x) + W for x in w_nodes}
        boundary = np.array(sorted(pos[d] for d in bset if d in pos), dtype=np.int64)
        subs.append(Substructure(b, x_nodes, free, K, M, boundary, offset))
        offset += len(free)
    by_name = {s.beam.name: s for s in subs}
    n = offset

    def tangential_row(x):
        return interface_rows(cfg, subs, x)[1]

    gap_rows = np.zeros((2 * len(x_pairs), n))
    for j, x in enumerate(x_pairs):
        gap_rows[2 * j], gap_rows[2 * j + 1] = interface_rows(cfg, subs, x)

    point_rows = np.zeros((len(p.points), n))
    for i, pt in enumerate(p.points):
        point_rows[i, by_name[pt.beam].dof(pt.x_m, W)] = 1.0
    exc = next(pt for pt in p.points if pt.name == p.excitation_point)
    b_exc = np.zeros(n)
    b_exc[by_name[exc.beam].dof(exc.x_m, W)] = 1.0

    n_p = len(x_pairs)
    a = cfg.actuator
    k_adaptive = a.k_stack * a.k_screw / (a.k_stack + a.k_screw)
    bolt_rows = np.array([pressure_weights(x_pairs, s.x_m, screw_cone_radius(cfg, s)) @ gap_rows[0::2]
                          for s in screws]).reshape(len(screws), n)
    bolt_k = np.array([k_adaptive if s.adaptive else s.stiffness_N_m for s in screws], dtype=float)
    bolt_F = np.array([0.0 if s.adaptive else s.F_N for s in screws], dtype=float)
    # a bolt pulls the upper beam down and the lower beam up at the pairs of its cone: nodal
    # forces -F times its (weighted) normal-gap row
    adaptive = adaptive_screw(cfg)
    i_a = -1 if adaptive is None else screws.index(adaptive)
    b_N1 = np.zeros(n) if adaptive is None else -bolt_rows[i_a]
    u_rel_row = np.zeros(n) if adaptive is None else tangential_row(adaptive.x_m)
    f_const = -(bolt_F @ bolt_rows)
    area = interface_width(cfg) * tributary_lengths(x_pairs) if n_p else np.zeros(0)
    return Structure(tuple(subs), x_pairs, gap_rows, tuple(pt.name for pt in p.points), point_rows,
                     u_rel_row, b_exc, b_N1, f_const, 0.0 if adaptive is None else adaptive.F_N,
                     area, itf.k_n_area * area, itf.k_t_area * area, np.full(n_p, itf.mu),
                     bolt_rows, bolt_k, bolt_F, tuple(s.name for s in screws), i_a)


def interface_width(cfg: Config) -> float:
    """Width of the contact interface [m]: the narrower of its two beams."""
    beams = {b.name: b for b in cfg.plant.beams}
    return min(beams[cfg.plant.interface.upper].width_m, beams[cfg.plant.interface.lower].width_m)


def screw_cone_radius(cfg: Config, screw) -> float:
    """Radius [m] of the screw's pressure cone at the interface (plant/bolts.py): VDI 2230's cone
    angle for the clamp length of both beams and their width, through the upper beam."""
    beams = {b.name: b for b in cfg.plant.beams}
    up, lo = beams[cfg.plant.interface.upper], beams[cfg.plant.interface.lower]
    tan_phi = vdi_cone_tan(screw.head_diameter_m, up.height_m + lo.height_m, min(up.width_m, lo.width_m))
    return cone_radius(screw.head_diameter_m, up.height_m, tan_phi)


def adaptive_cone_pairs(cfg: Config, x_pairs: np.ndarray) -> np.ndarray:
    """Boolean mask of the pairs inside the adaptive screw's pressure cone, |x - x_s| < R_c
    (plant/bolts.py); all False without an adaptive screw."""
    screw = adaptive_screw(cfg)
    if screw is None:
        return np.zeros(len(x_pairs), bool)
    return np.abs(np.asarray(x_pairs) - screw.x_m) < screw_cone_radius(cfg, screw)


def interface_rows(cfg: Config, subs: tuple[Substructure, ...] | list[Substructure], x: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(normal row, tangential row) of the interface at x [m] on the stacked physical vector:
    g_n = w_upper - w_lower [m] (> 0 open) and g_t = u at the bottom of the upper beam minus u
    at the top of the lower beam, u(z) = u - z theta [m]. At a node these are its DOFs; between
    nodes the elements' own interpolation (Substructure.field_row), so a contact pitch finer than
    the elements samples the same beams."""
    itf = cfg.plant.interface
    beams = {b.name: b for b in cfg.plant.beams}
    by_name = {s.beam.name: s for s in subs}
    lo, up = by_name[itf.lower], by_name[itf.upper]
    n = sum(s.n for s in subs)

    def field(sub, component):
        row = sub.field_row(x, component)
        return np.concatenate([row, np.zeros(n - len(row))])

    r_n = field(up, W) - field(lo, W)
    r_t = (field(up, U) + beams[itf.upper].height_m / 2 * field(up, THETA)
           - field(lo, U) + beams[itf.lower].height_m / 2 * field(lo, THETA))
    return r_n, r_t
