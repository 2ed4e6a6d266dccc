"""A 3-D solid reference of the paper's structure, written as a superelement (docs/superelement.md).

The two beams (configuration's plant.beams: the clamped main beam and the damper beam on its top)
as 27-node hexahedra (scikit-fem's ElementHex2, triquadratic: bending without shear locking),
assembled with scikit-fem (optional extra [fe]). The interface is node-to-node: the main beam's
top and the damper's bottom share their (x, y) grid over the damper, and each node pair is one
contact point with its tributary area (the integral of the node's quadratic shape function over
the face: Simpson's weights h/6, 4h/6, h/6 per element edge, in x times in y), gaps

    g_n = u_z(damper bottom) - u_z(main top),   g_t1 = u_x(damper) - u_x(main),   g_t2 = u_y(...) - u_y(...)

The bolts act over their head's footprint (radius head_diameter_m / 2) on the damper's top and
the main beam's bottom, each side's nodes weighted by their face integrals: the separation at a
bolt is s = r_b . u (damper top minus main bottom, mean over the footprints); the ordinary bolts'
springs (plant.screws' stiffness_N_m) enter K, their preloads f_bolts = -r_b F_N; the adaptive
bolt's row and stiffness (actuator k_stack in series with k_screw, as the 2-D plant) are kept for
the run-time F_N1. u_rel is the mean g_t1 (along the beams' axis x) of the interface points within
the adaptive bolt's footprint. Sensors: u_z of the main beam's top centre line nearest each
configured point; the excitation is a unit z force there (plant.exc_point).

Reduction: Craig-Bampton per beam with the interface, bolt-footprint and sensor DOFs kept and the
fixed-interface modes up to cutoff_hz (sparse: constraint modes by one sparse LU of K_ii, normal
modes by shift-invert Lanczos).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from frictionrt.plant.superelement import OPTIONAL_FE_HINT, Superelement, check


@dataclass(frozen=True)
class Beam3D:
    """One hexahedral beam: sparse K, M (clamped DOFs removed), the kept DOFs' map and node coordinates."""
    K: sp.csr_matrix
    M: sp.csr_matrix
    free: np.ndarray      # free DOF numbers of the full (unconstrained) numbering
    xyz: np.ndarray       # (nodes, 3) of the full numbering [m]
    nodal_dofs: np.ndarray  # (3, nodes): DOF of (x, y, z) of each node, full numbering


def _grid(x0, x1, pitch, fixed=()):
    """Element edges from x0 to x1 at most `pitch` apart, through the points `fixed`."""
    pts = sorted({x0, x1, *[f for f in fixed if x0 < f < x1]})
    out = [pts[0]]
    for a, b in zip(pts[:-1], pts[1:]):
        k = max(1, int(np.ceil((b - a) / pitch - 1e-9)))
        out += list(np.linspace(a, b, k + 1)[1:])
    return np.array(out)


def _beam(x_edges, width, y_elems, z0, height, E, nu, rho, clamp_x=None) -> Beam3D:
    try:
        from skfem import Basis, BilinearForm, ElementHex2, ElementVector, MeshHex
        from skfem.helpers import dot
        from skfem.models.elasticity import lame_parameters, linear_elasticity
    except ImportError:
        raise ImportError(f"the 3-D reference needs scikit-fem: {OPTIONAL_FE_HINT}") from None
    mesh = MeshHex.init_tensor(x_edges, np.linspace(-width / 2, width / 2, y_elems + 1),
                               np.array([z0 - height / 2, z0 + height / 2]))
    basis = Basis(mesh, ElementVector(ElementHex2()), intorder=4)
    K = linear_elasticity(*lame_parameters(E, nu)).assemble(basis)

    @BilinearForm
    def mass(u, v, w):
        return rho * dot(u, v)

    M = mass.assemble(basis)
    xyz = basis.doflocs[:, basis.nodal_dofs[0]].T           # nodes incl. edge/face/centre nodes
    ndofs = basis.N
    # all DOFs located at the same point as node k's x DOF: ElementVector orders (x, y, z) per location
    locs = basis.doflocs.T
    order = np.lexsort((locs[:, 2], locs[:, 1], locs[:, 0]))
    # group DOFs by location (three per point)
    key = np.round(locs[order] * 1e9).astype(np.int64)
    starts = np.flatnonzero(np.r_[True, np.any(np.diff(key, axis=0) != 0, axis=1)])
    triples = np.array([order[s:s + 3] for s in starts])
    # within a triple, which DOF is x, y, z: ElementVector puts component c at DOF index c mod 3 of a
    # location's block; sort each triple by DOF number (x < y < z numbering within a location)
    triples.sort(axis=1)
    xyz = locs[triples[:, 0]]
    nodal = triples.T.copy()
    fixed = np.zeros(ndofs, bool)
    if clamp_x is not None:
        fixed[nodal[:, np.abs(xyz[:, 0] - clamp_x) < 1e-12].ravel()] = True
    free = np.flatnonzero(~fixed)
    return Beam3D(K[free][:, free].tocsr(), M[free][:, free].tocsr(), free, xyz, nodal)


def _face_weights(xyz: np.ndarray, on_face: np.ndarray, x_edges: np.ndarray, y_edges: np.ndarray) -> np.ndarray:
    """Area [m^2] each node of a flat z = const face stands for: the integral of its triquadratic
    shape function over the face, i.e. the tensor product of the 1-D quadratic (Simpson) weights
    h/6, 4h/6, h/6 of each element edge, summed over the elements a node belongs to."""
    def w1d(edges, coords):
        w = np.zeros(len(coords))
        for a, b in zip(edges[:-1], edges[1:]):
            hh = b - a
            for c, f in ((a, 1 / 6), (0.5 * (a + b), 4 / 6), (b, 1 / 6)):
                w[np.abs(coords - c) < 1e-12] += f * hh
        return w
    wx = w1d(x_edges, xyz[on_face, 0])
    wy = w1d(y_edges, xyz[on_face, 1])
    out = np.zeros(len(xyz))
    out[on_face] = wx * wy
    return out


def reference_superelement(cfg, interface_pitch_m: float = 0.02, pitch_m: float = 0.02, width_elems: int = 1,
                           cutoff_hz: float = 4000.0, reduce: bool = True):
    """Build the 3-D reference of cfg's two beams; returns (Superelement, info dict).

    interface_pitch_m: element length over the damper (the contact points are the quadratic
    elements' nodes: pitch / 2 apart along x, width / (2 width_elems) across); pitch_m: element
    length elsewhere. reduce=False returns the full FE model (constrained DOFs removed) in the
    same format, for the check of the reduction. info: DOF counts and the full model's matrices.
    """
    pl = cfg.plant
    main, damper = pl.beams[0], pl.beams[1]
    x_d0, x_d1 = damper.x0_m, damper.x0_m + damper.length_m
    screws = pl.screws
    bolt_x = [s.x_m for s in screws]
    x_main = _grid(main.x0_m, main.x0_m + main.length_m, pitch_m, fixed=(x_d0, x_d1))
    # over the damper the interface pitch, shared by both beams
    inner = _grid(x_d0, x_d1, interface_pitch_m, fixed=bolt_x)
    x_main = np.unique(np.r_[x_main[(x_main < x_d0) | (x_main > x_d1)], inner])
    zc_main = main.z0_m
    zc_damp = damper.z0_m
    bm = _beam(x_main, main.width_m, width_elems, zc_main, main.height_m, main.E, main.nu, main.rho,
               clamp_x=pl.clamps[0].x_m)
    bd = _beam(inner, damper.width_m, width_elems, zc_damp, damper.height_m, damper.E, damper.nu, damper.rho)
    y_edges_m = np.linspace(-main.width_m / 2, main.width_m / 2, width_elems + 1)
    y_edges_d = np.linspace(-damper.width_m / 2, damper.width_m / 2, width_elems + 1)
    top_m = zc_main + main.height_m / 2
    bot_m = zc_main - main.height_m / 2
    bot_d = zc_damp - damper.height_m / 2
    top_d = zc_damp + damper.height_m / 2
    if abs(top_m - bot_d) > 1e-9:
        raise ValueError(f"the damper's bottom (z = {bot_d:g} m) does not lie on the main beam's top (z = {top_m:g} m)")
    # --- interface node pairs
    on_d = np.abs(bd.xyz[:, 2] - bot_d) < 1e-12
    idx_d = np.flatnonzero(on_d)
    key_m = {(round(x * 1e9), round(y * 1e9)): i for i, (x, y, z) in enumerate(bm.xyz) if abs(z - top_m) < 1e-12}
    idx_m = np.array([key_m[(round(bd.xyz[i, 0] * 1e9), round(bd.xyz[i, 1] * 1e9))] for i in idx_d])
    area = _face_weights(bd.xyz, on_d, inner, y_edges_d)[idx_d]
    n_m, n_d = bm.nodal_dofs.shape[1] * 3, bd.nodal_dofs.shape[1] * 3
    # full numbering -> free numbering of each beam
    pos_m = -np.ones(n_m, np.int64)
    pos_m[bm.free] = np.arange(len(bm.free))
    pos_d = -np.ones(n_d, np.int64)
    pos_d[bd.free] = np.arange(len(bd.free))
    Nm, Nd = len(bm.free), len(bd.free)
    N = Nm + Nd

    def dof_m(node, c):
        return pos_m[bm.nodal_dofs[c, node]]

    def dof_d(node, c):
        return Nm + pos_d[bd.nodal_dofs[c, node]]

    p = len(idx_d)
    rows = np.zeros((p, 3, N))
    for k, (i_d, i_m) in enumerate(zip(idx_d, idx_m)):
        for r, c in ((0, 2), (1, 0), (2, 1)):
            rows[k, r, dof_d(i_d, c)] += 1.0
            if dof_m(i_m, c) >= 0:
                rows[k, r, dof_m(i_m, c)] -= 1.0
    # --- bolts: footprint rows (damper top minus main bottom, face-weighted means)
    wt_top_d = _face_weights(bd.xyz, np.abs(bd.xyz[:, 2] - top_d) < 1e-12, inner, y_edges_d)
    wt_bot_m = _face_weights(bm.xyz, np.abs(bm.xyz[:, 2] - bot_m) < 1e-12, x_main, y_edges_m)

    def footprint(xyz, w, xs, R):
        sel = np.hypot(xyz[:, 0] - xs, xyz[:, 1]) <= R + 1e-12
        ww = np.where(sel, w, 0.0)
        if ww.sum() <= 0:
            raise ValueError(f"the bolt at x = {xs:g} m has no nodes in its footprint (radius {R:g} m): refine the mesh")
        return ww / ww.sum()

    K = sp.block_diag([bm.K, bd.K]).tolil()
    f_bolts = np.zeros(N)
    r_adapt = None
    k_adapt = 0.0
    keep = set()
    for s in screws:
        R = 0.5 * s.head_diameter_m
        wd = footprint(bd.xyz, wt_top_d, s.x_m, R)
        wm = footprint(bm.xyz, wt_bot_m, s.x_m, R)
        r = np.zeros(N)
        for i in np.flatnonzero(wd):
            r[dof_d(i, 2)] += wd[i]
            keep.add(dof_d(i, 2))
        for i in np.flatnonzero(wm):
            if dof_m(i, 2) >= 0:
                r[dof_m(i, 2)] -= wm[i]
                keep.add(dof_m(i, 2))
        if s.adaptive:
            a = cfg.actuator
            r_adapt = r
            k_adapt = 1.0 / (1.0 / a.k_stack + 1.0 / a.k_screw)
        else:
            f_bolts -= r * s.F_N
            if s.stiffness_N_m > 0:
                nz = np.flatnonzero(r)
                K[np.ix_(nz, nz)] = K[np.ix_(nz, nz)].toarray() + s.stiffness_N_m * np.outer(r[nz], r[nz])
    K = K.tocsr()
    M = sp.block_diag([bm.M, bd.M]).tocsr()
    # --- u_rel: mean g_t1 of the interface points in the adaptive bolt's footprint (area-weighted)
    ad = [s for s in screws if s.adaptive]
    u_rel = None
    if ad:
        sel = np.hypot(bd.xyz[idx_d, 0] - ad[0].x_m, bd.xyz[idx_d, 1]) <= 0.5 * ad[0].head_diameter_m + 1e-12
        wts = np.where(sel, area, 0.0)
        u_rel = (wts / wts.sum()) @ rows[:, 1, :]
    # --- sensors: u_z on the main beam's top centre line
    names, srows = [], []
    for pt in pl.points:
        cand = np.flatnonzero((np.abs(bm.xyz[:, 2] - top_m) < 1e-12) & (np.abs(bm.xyz[:, 1]) < 1e-12))
        i = cand[np.argmin(np.abs(bm.xyz[cand, 0] - pt.x_m))]
        r = np.zeros(N)
        r[dof_m(i, 2)] = 1.0
        names.append(pt.name)
        srows.append(r)
        keep.add(dof_m(i, 2))
    # the tip's lateral motion (u_y), to tell vertical bending from lateral bending and torsion
    cand = np.flatnonzero((np.abs(bm.xyz[:, 2] - top_m) < 1e-12) & (np.abs(bm.xyz[:, 1]) < 1e-12))
    i = cand[np.argmax(bm.xyz[cand, 0])]
    r = np.zeros(N)
    r[dof_m(i, 1)] = 1.0
    names.append("tip_y")
    srows.append(r)
    keep.add(dof_m(i, 1))
    srows = np.array(srows)
    exc = srows[[names.index(pl.excitation_point)]]
    info = {"n_full": N, "n_points": p, "xyz": bd.xyz[idx_d], "K_full": K, "M_full": M,
            "contact_rows_full": rows, "adaptive_row_full": r_adapt, "adaptive_k": k_adapt}
    contact_dofs = np.flatnonzero(np.any(rows != 0, axis=(0, 1)))
    keep |= set(contact_dofs.tolist())
    boundary = np.array(sorted(keep))
    if not reduce:
        se = Superelement(M=M.toarray(), K=K.toarray(), contact_rows=rows, contact_area=area,
                          contact_xyz=bd.xyz[idx_d], contact_normal=np.tile([0.0, 0.0, 1.0], (p, 1)),
                          f_bolts=f_bolts, adaptive_row=r_adapt, adaptive_k=k_adapt, u_rel_row=u_rel,
                          u_rel_direction=np.array([1.0, 0.0, 0.0]), sensor_rows=srows, sensor_names=tuple(names),
                          excitation=exc, excitation_names=(pl.excitation_point,), source="fe3d full")
        return check(se), info
    T, f_fixed = craig_bampton_sparse(K, M, boundary, cutoff_hz)
    info.update(n_reduced=T.shape[1], n_boundary=len(boundary), fixed_interface_hz=f_fixed)
    Kr = T.T @ (K @ T)
    Mr = T.T @ (M @ T)
    Kr, Mr = 0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T)

    def red(v):
        return None if v is None else v @ T
    se = Superelement(M=Mr, K=Kr, contact_rows=rows @ T, contact_area=area, contact_xyz=bd.xyz[idx_d],
                      contact_normal=np.tile([0.0, 0.0, 1.0], (p, 1)), f_bolts=T.T @ f_bolts,
                      adaptive_row=red(r_adapt), adaptive_k=k_adapt, u_rel_row=red(u_rel),
                      u_rel_direction=np.array([1.0, 0.0, 0.0]), sensor_rows=srows @ T, sensor_names=tuple(names),
                      excitation=exc @ T, excitation_names=(pl.excitation_point,),
                      source=f"fe3d Craig-Bampton ({len(boundary)} boundary DOFs, {len(f_fixed)} modes <= {cutoff_hz:g} Hz)")
    info["T"] = T
    return check(se), info


def craig_bampton_sparse(K: sp.spmatrix, M: sp.spmatrix, boundary: np.ndarray, cutoff_hz: float):
    """Craig-Bampton basis T (dense, n x (n_b + n_modes)) of sparse K, M (plant.craig_bampton's
    partition): Psi = -K_ii^-1 K_ib by one sparse LU, the fixed-interface modes below cutoff_hz by
    shift-invert Lanczos. Returns (T, fixed-interface frequencies [Hz])."""
    n = K.shape[0]
    b = np.asarray(boundary, np.int64)
    i = np.setdiff1d(np.arange(n), b)
    K, M = K.tocsc(), M.tocsc()
    Kii = K[i][:, i].tocsc()
    lu = spla.splu(Kii)
    Psi = -lu.solve(K[i][:, b].toarray())
    T = np.zeros((n, len(b)))
    T[b, np.arange(len(b))] = 1.0
    T[i, :] = Psi
    lim = (2 * np.pi * cutoff_hz) ** 2
    k = 12
    Mii = M[i][:, i].tocsc()
    op = spla.LinearOperator(Kii.shape, matvec=lu.solve)
    v0 = np.random.default_rng(0).standard_normal(len(i))   # ARPACK's start: fixed, so the same bits each run
    while True:
        k = min(k, len(i) - 2)
        lam, Phi = spla.eigsh(Kii, k=k, M=Mii, sigma=0.0, OPinv=op, which="LM", v0=v0)
        if lam.max() > lim or k >= len(i) - 2:
            break
        k *= 2
    sel = lam <= lim
    lam, Phi = lam[sel], Phi[:, sel]
    o = np.argsort(lam)
    Tm = np.zeros((n, len(o)))
    Tm[i, :] = Phi[:, o]
    return np.hstack([T, Tm]), np.sqrt(lam[o]) / (2 * np.pi)


def full_stuck_frequencies_hz(info: dict, se_full: Superelement | None, k_n: np.ndarray, k_t: np.ndarray,
                              n_modes: int = 8):
    """The full 3-D FE model's lowest eigenfrequencies [Hz] with every contact point stuck (k_n, k_t
    springs on its gaps), by shift-invert Lanczos on the sparse matrices. se_full None: the full
    model's interface and bolt rows from info (``reference_superelement``'s), so a fine mesh is
    checked without a dense full superelement."""
    if se_full is None:
        from types import SimpleNamespace
        se_full = SimpleNamespace(contact_rows=info["contact_rows_full"], adaptive_row=info["adaptive_row_full"],
                                  adaptive_k=info["adaptive_k"])
    R = se_full.contact_rows
    p, d, N = R.shape
    kc = np.zeros(p * d)
    kc[0::d] = k_n
    for a in range(1, d):
        kc[a::d] = k_t
    Rs = sp.csr_matrix(R.reshape(p * d, N))
    K = info["K_full"] + Rs.T @ sp.diags(kc) @ Rs
    if se_full.adaptive_row is not None:
        r = sp.csr_matrix(se_full.adaptive_row[None])
        K = K + se_full.adaptive_k * (r.T @ r)
    v0 = np.random.default_rng(0).standard_normal(K.shape[0])   # ARPACK's start: fixed, so the same bits each run
    lam = spla.eigsh(K.tocsc(), k=n_modes, M=info["M_full"].tocsc(), sigma=0.0, which="LM", v0=v0,
                     return_eigenvectors=False)
    return np.sort(np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi))
