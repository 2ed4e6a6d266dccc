"""Design time: from the configuration to the constant arrays of the plant step.

    FE beams (plant.structure) --Craig-Bampton per beam--> reduced (K_r, M_r)
        --eigen per beam--> modal basis V (mass-normalised), omega, zeta (bare-beam damping)
        --Newmark constants--> PlantParams (plant.newmark)

The full FE model uses the same path with T = I, so full and reduced models are stepped by
the same kernel with the same integrator.

Length: the one path from the configuration to the kernel's arrays (modal basis, period matching
for both step schemes, the quasi-static condensation, the bolts' reference, the static state) and
the caches that let a fit rebuild it cheaply; its parts share PlantParams' layout.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from frictionrt.plant.contact import _jenkins_pair
from frictionrt.plant.craig_bampton import craig_bampton
from frictionrt.plant.newmark import FACTOR_SLOTS, MAX_UPDATES, N_ENERGY, PlantParams, PlantWork, _plant_step
from frictionrt.plant.structure import Structure, build_structure
from frictionrt.plant.stuck_match import reference_substeps, stuck_period_matched
from frictionrt.rt.common.blas import check as check_blas
from frictionrt.rt.common.codegen import check as check_codegen
from frictionrt.rt.common.config import STEP_SCHEMES, Config, with_sets

RIGID_BODY_RAD_S = 2 * np.pi * 0.1  # below 0.1 Hz a substructure mode is a rigid-body mode


@dataclass(frozen=True)
class PlantModel:
    """A built plant: kernel arrays plus what is needed to interpret them."""
    cfg: Config
    structure: Structure
    params: PlantParams
    Phi: np.ndarray           # (n_dof, n) physical <- modal
    omega: np.ndarray         # (n,) [rad/s] uncoupled substructure frequencies
    reduced: bool

    @property
    def n(self) -> int:
        """Number of (modal) coordinates stepped."""
        return len(self.omega)

    @property
    def n_pairs(self) -> int:
        return self.structure.n_pairs

    @property
    def n_sliders(self) -> int:
        """Sliders per pair: 1 (Jenkins element) or the elements of the Iwan element."""
        return len(self.params.iwan_k)

    @property
    def state_size(self) -> int:
        return 2 * self.n + (2 + self.n_sliders) * self.n_pairs + N_ENERGY + self._n_scheme_state

    @property
    def _n_scheme_state(self) -> int:
        """Slots of the generalized-alpha step's own state: accelerations of the stepped modes and
        the pairs' normal gap rates (none for the trapezoid)."""
        return self.params.n_dyn + 3 * self.n_pairs + 2 if self.params.scheme == 1 else 0

    def state_slots(self) -> dict[str, slice]:
        """Named slots of the state vector (the one table the kernel's offsets follow); the
        sliders w are pair-major (pair j's elements at j N .. j N + N - 1)."""
        n, p, nw = self.n, self.n_pairs, self.n_pairs * self.n_sliders
        o = 2 * n + nw + 2 * p
        names = ["E_fric", "E_damp", "W_exc", "W_screw"]
        slots = {"q": slice(0, n), "qd": slice(n, 2 * n),
                 "w": slice(2 * n, 2 * n + nw), "g": slice(2 * n + nw, o)}
        slots.update({nm: slice(o + i, o + i + 1) for i, nm in enumerate(names)})
        if self.params.scheme == 1:   # generalized-alpha: a (n_dyn) [1/s^2 modal], gap rates (p) [m/s]
            o += len(names)
            slots["acc"] = slice(o, o + self.params.n_dyn)
            o += self.params.n_dyn
            slots["lam_prev"] = slice(o, o + 2 * p)
            slots["gn_rate"] = slice(o + 2 * p, o + 3 * p)
            slots["u_prev"] = slice(o + 3 * p, o + 3 * p + 2)
        return slots

    def output_labels(self) -> list[tuple[str, str]]:
        """(name, unit) of each entry of the step's output vector y."""
        pts = self.structure.point_names
        p = self.n_pairs
        lab = [(f"w_{s}", "m") for s in pts] + [(f"v_{s}", "m/s") for s in pts] + \
              [(f"a_{s}", "m/s^2") for s in pts] + [("u_rel", "m"), ("v_rel", "m/s")]
        for sym, unit in (("g_n", "m"), ("g_t", "m"), ("f_n", "N"), ("f_t", "N")):
            lab += [(f"{sym}_{j}", unit) for j in range(p)]
        lab += [("E_fric", "J"), ("E_damp", "J"), ("W_exc", "J"), ("W_screw", "J"), ("newton_iter", "-"),
                ("substep_fallbacks", "-")]
        lab += [(f"abar_{s}", "m/s^2") for s in pts]
        st = self.structure
        for b, name in enumerate(st.bolt_names):
            lab += [(f"g_bolt_{name}", "m"), ("F_N1" if b == st.adaptive else f"F_bolt_{name}", "N")]
        lab += [("dF_N1", "N")]
        return lab

    def output_index(self) -> dict[str, int]:
        return {name: i for i, (name, _) in enumerate(self.output_labels())}

    def new_work(self, factor_slots: int = FACTOR_SLOTS) -> PlantWork:
        """Scratch buffers of the plant step, with factor_slots contact patterns' factors kept
        (``frictionrt.plant.newmark._use_cached``; 1: only the last pattern's), plus one slot for patterns
        with a pair in transition."""
        n, m = self.n, 2 * self.n_pairs
        p = m // 2
        K = int(factor_slots) + 1   # and the transitions' slot
        i64 = np.int64
        return PlantWork(q_pred=np.zeros(n), q_g=np.zeros(n), qdd_lin=np.zeros(n), f_c=np.zeros(n),
                         g_pred=np.zeros(m), g0=np.zeros(m), lam=np.zeros(m),
                         lam1=np.zeros(m), lamd=np.zeros(m), w_new=np.zeros(p * self.n_sliders), d=np.zeros(3 * p),
                         code=np.zeros(p, dtype=i64), r=np.zeros(m), dg=np.zeros(m), g_old=np.zeros(m),
                         LU=np.zeros((m, m)), Jinv=np.zeros((K, m, m)), piv=np.zeros((K, m), dtype=i64),
                         act=np.zeros(p, dtype=i64),
                         ra=np.zeros(m), ry=np.zeros(m), z=np.zeros(m), pattern=np.full((K, p), -1, dtype=i64),
                         mu_eff=self.params.mu.copy(),
                         d_fact=np.zeros((K, 3 * p)), upd=np.zeros(1 + 2 * MAX_UPDATES, dtype=i64),
                         upd_delta=np.zeros(MAX_UPDATES), cap=np.zeros((MAX_UPDATES, MAX_UPDATES + 1)),
                         Z=np.zeros((K, p, m)), z_ok=np.zeros((K, p), dtype=i64), slot=np.zeros(2, dtype=i64),
                         last_use=np.zeros(K, dtype=i64), key=np.zeros(K, dtype=i64), gs=np.zeros(p))

    def initial_state(self, F_N1: float | None = None) -> np.ndarray:
        """Static equilibrium under the screw forces (sliders from zero), at rest."""
        F = self.structure.F_N1_initial if F_N1 is None else F_N1
        q, w, g = static_equilibrium(self, F)
        x = np.zeros(self.state_size)
        sl = self.state_slots()
        x[sl["q"]] = q
        x[sl["w"]] = w
        x[sl["g"]] = g
        if "lam_prev" in sl:   # generalized-alpha: the pairs' end-point forces of the static state
            x[sl["lam_prev"]] = contact_forces(self, g, w)[0]
            x[sl["u_prev"]] = (0.0, F)   # the inputs the static state holds
        return x

    def step(self, k: int, x: np.ndarray, u: np.ndarray, x_next: np.ndarray, y: np.ndarray,
             work: PlantWork) -> int:
        """Checked wrapper of the plant kernel (use ``_plant_step`` directly in loops)."""
        if x.shape != (self.state_size,) or x_next.shape != x.shape:
            raise ValueError(f"state must have shape ({self.state_size},), got {x.shape}, {x_next.shape}")
        if u.shape != (2,) or y.shape != (len(self.output_labels()),):
            raise ValueError("u must be (F_exc [N], F_N1 [N]); y must have one entry per output label")
        return _plant_step(np.int64(k), x, u, self.params, x_next, y, work)


def _modal_basis(K: np.ndarray, M: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mass-normalised eigenbasis Phi = T V of the (reduced) pair T^T K T, T^T M T."""
    Kr = T.T @ K @ T
    Mr = T.T @ M @ T
    lam, V = sla.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    return np.sqrt(np.maximum(lam, 0.0)), T @ V


_BASES: OrderedDict = OrderedDict()   # open_contact_basis's cache, most recent last
_BASES_KEPT = 8
_BASES_LOCK = threading.Lock()


def open_contact_basis(st: Structure, cutoff_hz: float, reduced: bool) -> tuple[np.ndarray, np.ndarray]:
    """(omega [rad/s], Phi) of the bolted assembly with the contact open: each beam reduced by
    Craig-Bampton (fixed-interface modes up to ``cutoff_hz``; the identity if not ``reduced``),
    then one mass-normalised eigenbasis of the beams and the bolts' springs (``_modal_basis``).

    Cached for the last few structures whose beams are the same read-only arrays
    (``plant.structure.beam_matrices`` returns the same objects for the same beams) and whose bolts
    and boundaries are equal: the same inputs, so the same bits; the arrays returned are read-only."""
    key = (tuple((id(s.K), id(s.M), s.boundary.tobytes()) for s in st.subs), st.bolt_rows.tobytes(),
           st.bolt_k.tobytes(), float(cutoff_hz), bool(reduced))
    keep = all(not s.K.flags.writeable and not s.M.flags.writeable for s in st.subs)
    with _BASES_LOCK:
        hit = _BASES.get(key) if keep else None
        if hit is not None and all(a is s.K and b is s.M for (a, b), s in zip(hit[0], st.subs)):
            _BASES.move_to_end(key)
            return hit[1], hit[2]
    T = sla.block_diag(*[craig_bampton(sub.K, sub.M, sub.boundary, cutoff_hz)[0] if reduced
                         else np.eye(sub.n) for sub in st.subs])
    # the bolts couple the beams: one modal basis of the bolted assembly (contact open)
    K = sla.block_diag(*[sub.K for sub in st.subs]) + st.bolt_stiffness()
    omega, Phi = _modal_basis(K, sla.block_diag(*[sub.M for sub in st.subs]), T)
    omega.setflags(write=False)
    Phi.setflags(write=False)
    if keep:
        with _BASES_LOCK:   # the beams' arrays are held, so their ids in the key stay theirs
            _BASES[key] = (tuple((s.K, s.M) for s in st.subs), omega, Phi)
            while len(_BASES) > _BASES_KEPT:
                _BASES.popitem(last=False)
    return omega, Phi


PERIOD_MATCH_MAX = 1.0   # omega h above which a stepped mode is not period-matched (m would fall below 0.85)


def period_matched(omega: np.ndarray, c: np.ndarray, zeta: float, dyn: np.ndarray, h: float,
                   on: bool) -> tuple[np.ndarray, np.ndarray]:
    """(m_step [-], c_step [1/s]) of the stepped modes (plant.newmark, "Period matching"): modal mass
    (omega / omega_d)^2, omega_d = (2/h) tan(omega h / 2), and damping 2 zeta omega^2 / omega_d x
    omega h / sin(omega h), so that the trapezoidal rule's free mode has the frequency omega and the
    damping ratio zeta; 1 and c where ``on`` is False, for rigid-body and quasi-static modes and
    above omega h = PERIOD_MATCH_MAX."""
    x = omega * h
    match = on & (dyn > 0) & (omega > 0.0) & (x < PERIOD_MATCH_MAX)
    xs = np.where(match, x, 1.0)
    omega_d = 2.0 / h * np.tan(0.5 * xs)
    m_step = np.where(match, (xs / h / omega_d) ** 2, 1.0)
    c_step = np.where(match, 2.0 * zeta * (xs / h) ** 2 / omega_d * xs / np.sin(xs), c)
    return m_step, c_step


def generalized_alpha(rho_inf: float) -> tuple[float, float, float, float]:
    """(alpha_m, alpha_f, beta, gamma) of generalized-alpha with spectral radius rho_inf at
    omega h -> infinity, second order and with the least low-frequency damping for it (Chung &
    Hulbert 1993, eq. 25): alpha_m = (2 rho - 1)/(rho + 1), alpha_f = rho/(rho + 1),
    gamma = 1/2 - alpha_m + alpha_f, beta = (1 - alpha_m + alpha_f)^2 / 4. rho_inf = 1 gives
    (1/2, 1/2, 1/4, 1/2): the trapezoidal rule."""
    r = float(rho_inf)
    am, af = (2.0 * r - 1.0) / (r + 1.0), r / (r + 1.0)
    return am, af, 0.25 * (1.0 - am + af) ** 2, 0.5 - am + af


def alpha_amplification(m: float, c: float, k: float, h: float, coef) -> np.ndarray:
    """The 3 x 3 map (q, v, a)_n -> (q, v, a)_n+1 of one free mode (mass m, damping c, stiffness k)
    under generalized-alpha with coef = (alpha_m, alpha_f, beta, gamma) and step h (design time)."""
    am, af, beta, gamma = coef
    # rows: the balance at the alpha point, then the Newmark updates of q and v, in (q1, v1, a1)
    A1 = np.array([[(1 - af) * k, (1 - af) * c, (1 - am) * m], [1.0, 0.0, -beta * h * h], [0.0, 1.0, -gamma * h]])
    A0 = np.array([[-af * k, -af * c, -am * m], [1.0, h, (0.5 - beta) * h * h], [0.0, 1.0, (1 - gamma) * h]])
    return np.linalg.solve(A1, A0)


def alpha_period_matched(omega: np.ndarray, c: np.ndarray, zeta: float, dyn: np.ndarray, h: float, on: bool,
                         coef) -> tuple[np.ndarray, np.ndarray]:
    """(m_step [-], c_step [1/s]) of the stepped modes under generalized-alpha: per mode with
    omega h < PERIOD_MATCH_MAX the modal mass and damping for which the step's free mode has the
    frequency omega and the damping ratio zeta (the principal eigenvalues of ``alpha_amplification``
    at exp((-zeta +- i sqrt(1 - zeta^2)) omega h)), by Newton on (ln m, c) from (0, c); 1 and c
    elsewhere and where ``on`` is False (the trapezoid's counterpart: ``period_matched``)."""
    m_step, c_step = np.ones_like(omega), np.array(c, dtype=float)
    if not on:
        return m_step, c_step
    for i in np.flatnonzero((dyn > 0) & (omega > 0.0) & (omega * h < PERIOD_MATCH_MAX)):
        w = float(omega[i])
        target = np.array([-zeta * w * h, np.sqrt(1.0 - zeta**2) * w * h])

        def resid(x):
            lam = np.linalg.eigvals(alpha_amplification(np.exp(x[0]), x[1], w * w, h, coef))
            lp = lam[np.argmax(np.abs(lam.imag))]
            return np.array([np.log(abs(lp)), abs(np.angle(lp))]) - target

        x = np.array([0.0, float(c[i])])
        for _ in range(30):
            r = resid(x)
            if np.max(np.abs(r)) < 1e-14 * w * h:
                break
            J = np.empty((2, 2))
            for j, dx in enumerate((1e-7, 1e-7 * max(w, 1.0))):
                xp = x.copy()
                xp[j] += dx
                J[:, j] = (resid(xp) - r) / dx
            x = x - np.linalg.solve(J, r)
        m_step[i], c_step[i] = np.exp(x[0]), x[1]
    return m_step, c_step


_PLANTS: OrderedDict = OrderedDict()   # build_plant's last models by configuration, most recent last
_PLANTS_KEPT = 4


def build_plant(cfg: Config, reduced: bool | None = None) -> PlantModel:
    """Build the plant from the configuration (``reduced`` overrides ``cfg.plant.reduced``).

    A pure function of ``cfg`` and ``reduced``: the last few models are kept by the configuration's
    repr and returned again for an equal one (every array of a model is read-only)."""
    check_codegen()  # the kernels' fixed code-generation target (rt/common/codegen.py)
    check_blas()     # the design's OpenBLAS kernels and one thread (rt/common/blas.py)
    reduced = cfg.plant.reduced if reduced is None else reduced
    key = (repr(cfg), bool(reduced))
    with _BASES_LOCK:
        model = _PLANTS.get(key)
        if model is not None:
            _PLANTS.move_to_end(key)
            return model
    model = _build_plant(cfg, reduced)
    with _BASES_LOCK:
        _PLANTS[key] = model
        while len(_PLANTS) > _PLANTS_KEPT:
            _PLANTS.popitem(last=False)
    return model


def _build_plant(cfg: Config, reduced: bool) -> PlantModel:
    """build_plant's work, uncached."""
    st = build_structure(cfg)
    omega, Phi = open_contact_basis(st, cfg.plant.cb_cutoff_hz, reduced)
    # rigid-body modes of free substructures (numerically ~0): exactly 0, undamped
    omega = np.where(omega < RIGID_BODY_RAD_S, 0.0, omega)
    # modes above plant.quasi_static_hz have no inertia (docs/plant.md 2.6): the step would only
    # ring them at Nyquist (the trapezoidal rule's amplification tends to -1 for omega h >> 1)
    dyn = (omega <= 2 * np.pi * cfg.plant.quasi_static_hz).astype(float)
    c = np.where(omega > 0.0, 2.0 * cfg.plant.modal_damping * omega, 0.0) * dyn
    h = cfg.dt_s / cfg.plant.substeps
    h_fine = h / cfg.plant.fallback_split
    theta = float(cfg.plant.quasi_static_theta)
    scheme = STEP_SCHEMES.index(cfg.plant.step_scheme)
    # the trapezoid's are generalized-alpha's at rho_inf = 1 (the contact laws weigh their end points by them)
    am, af, beta, gamma = generalized_alpha(cfg.plant.step_rho_inf if scheme == 1 else 1.0)
    if scheme == 1:   # the quasi-static modes and the contact law at the end point (theta = 0)
        theta = 0.0
        m_step, c_step = alpha_period_matched(omega, c, cfg.plant.modal_damping, dyn, h, cfg.plant.period_match,
                                              (am, af, beta, gamma))
        s2, s2_fine = (np.where(dyn > 0, (1.0 - af) * hh**2 * beta
                                / ((1.0 - am) * m_step + (1.0 - af) * (gamma * hh * c_step + beta * hh**2 * omega**2)),
                                (1.0 + theta) / np.maximum(omega, 1.0)**2) for hh in (h, h_fine))
    else:
        m_step, c_step = period_matched(omega, c, cfg.plant.modal_damping, dyn, h, cfg.plant.period_match)
        s2, s2_fine = (np.where(dyn > 0, 2.0 / (omega**2 + 2.0 / hh * c_step + 4.0 / hh**2 * m_step),
                                (1.0 + theta) / np.maximum(omega, 1.0)**2) for hh in (h, h_fine))
    G = np.ascontiguousarray(st.gap_rows @ Phi)
    out_rows = np.ascontiguousarray(np.vstack([st.point_rows, st.u_rel_row]) @ Phi)
    params = PlantParams(
        omega2=omega**2, dyn=dyn, c=c, c_step=c_step, m_step=m_step, s2=s2, G=G,
        W=np.ascontiguousarray((G * s2) @ G.T),
        b_exc=Phi.T @ st.b_exc, b_N1=Phi.T @ st.b_N1, f_const=Phi.T @ st.f_const,
        out_rows=out_rows, out_G=np.ascontiguousarray((out_rows * (dyn / m_step)) @ G.T),
        k_n=st.k_n.copy(), k_t=st.k_t.copy(), mu=st.mu.copy(),
        c_n=st.k_n * cfg.plant.interface.tau_s, c_t=st.k_t * cfg.plant.interface.tau_s,
        dashpot_depth=float(cfg.plant.interface.dashpot_depth_m), h=float(h),
        substeps=int(cfg.plant.substeps), s2_fine=s2_fine, W_fine=np.ascontiguousarray((G * s2_fine) @ G.T),
        h_fine=float(h_fine), qs_theta=theta, fine_split=int(cfg.plant.fallback_split),
        tol=float(cfg.plant.newton_tol_m),
        max_iter=int(cfg.plant.newton_max_iter), static_excess=float(cfg.plant.interface.static_excess),
        stribeck_v=float(cfg.plant.interface.stribeck_velocity_m_s), **iwan_fractions(cfg),
        bolt_rows=np.ascontiguousarray(st.bolt_rows @ Phi), bolt_k=st.bolt_k.copy(), bolt_F=st.bolt_F.copy(),
        bolt_ref=np.zeros(len(st.bolt_k)), bolt_adaptive=int(st.adaptive),
        n_dyn=0, gq_exc=np.zeros(0), gq_N1=np.zeros(0), gq_const=np.zeros(0),   # set last (_with_quasi_static_loads)
        scheme=scheme, ga_am=am, ga_af=af, ga_beta=beta, ga_gamma=gamma, law_w0=0.0 if scheme == 1 else 0.5)
    model = PlantModel(cfg, st, params, Phi, omega, reduced)
    model = PlantModel(cfg, st, _with_bolt_reference(model, cfg.actuator.F0_N), Phi, omega, reduced)
    if cfg.plant.condense_quasi_static:
        model = condense_quasi_static(model)
    model = PlantModel(cfg, st, _with_quasi_static_loads(model.params), model.Phi, model.omega, reduced)
    if cfg.plant.period_match_stuck and cfg.plant.period_match:   # docs/plant.md 2.9
        params = stuck_period_matched(model, stuck_reference(cfg, reduced))[0]
        model = PlantModel(cfg, st, params, model.Phi, model.omega, reduced)
    for a in list(model.params) + [model.Phi, model.omega] + [getattr(st, f) for f in st.__dataclass_fields__]:
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    return model


def stuck_reference(cfg: Config, reduced: bool | None = None) -> PlantModel:
    """The plant whose stuck poles ``plant.period_match_stuck`` matches: the same configuration at
    ``plant.stuck_match.reference_substeps`` substeps with the open-contact period matching only
    (docs/plant.md 2.9)."""
    return build_plant(with_sets(cfg, [f"plant.substeps={reference_substeps(cfg.plant.substeps)}",
                                       "plant.period_match_stuck=false"]), reduced)


CONDENSE_RTOL = 1e-12  # directions of the reachable subspace below this relative size are round-off


def condense_quasi_static(model: PlantModel) -> PlantModel:
    """The quasi-static modes (dyn = 0) replaced by their Ritz modes on the subspace the step can
    reach (docs/plant.md 2.7); exact for everything the step computes.

    A quasi-static mode has no inertia: its step is q1 = (1 + theta) Omega^-1 f - theta q0
    (plant.newmark), f = B u + G^T Lambda its load from the inputs and constant screws (B) and
    the contact (G). From the static initial state, q therefore never leaves
    R = range(Omega^-1 [B, G^T, t]) (t: the u_rel pair's load, so that the static compliance at the
    adaptive screw is kept as well), of dimension at most 3 + 2p + 1 however many modes lie
    above plant.quasi_static_hz. With a basis V of R that is Omega-orthonormal, the Ritz pair
    (V^T Omega V, V^T V) gives M-orthonormal, stiffness-diagonal coordinates Vr with Ritz
    frequencies within the quasi-static modes' range, and Vr diag(omega_r^-2) Vr^T f =
    Omega^-1 f for every f whose response lies in R: each step, the static initial state, the
    gaps, outputs and energies are those of all the modes (to round-off; tested). Only the
    quasi-static modes' inertia, which the step ignores anyway, is changed in the linear
    analyses that include it (``stuck_frequencies_hz``: 1.1e-5 relative at most below 1.1 kHz).
    """
    p = model.params
    qs = p.dyn == 0
    if not qs.any():
        return model
    loads = np.column_stack([p.b_exc, p.b_N1, p.f_const, p.G.T, model.Phi.T @ model.structure.u_rel_row])[qs]
    om = np.sqrt(p.omega2[qs])
    U, sv, _ = np.linalg.svd(loads / om[:, None], full_matrices=False)   # Omega^(1/2) Omega^-1 loads
    U = U[:, sv > CONDENSE_RTOL * sv[0]]
    s, Y = np.linalg.eigh(U.T @ (U / om[:, None] ** 2))   # V^T V with V = Omega^(-1/2) U: s = omega_r^-2
    s, Y = s[::-1], Y[:, ::-1]                             # ascending Ritz frequencies
    Vr = (U / om[:, None]) @ Y / np.sqrt(s)               # M-orthonormal, V^T Omega V = diag(1/s)
    n_dyn = int((~qs).sum())
    T = np.zeros((len(qs), n_dyn + Vr.shape[1]))
    T[np.flatnonzero(~qs), np.arange(n_dyn)] = 1.0
    T[np.flatnonzero(qs), n_dyn:] = Vr
    omega = np.concatenate([model.omega[~qs], 1.0 / np.sqrt(s)])
    theta = p.qs_theta
    modal = {k: np.concatenate([getattr(p, k)[~qs], v]) for k, v in
             (("dyn", np.zeros(len(s))), ("c", np.zeros(len(s))), ("c_step", np.zeros(len(s))),
              ("m_step", np.ones(len(s))), ("s2", (1.0 + theta) * s), ("s2_fine", (1.0 + theta) * s))}
    params = p._replace(
        omega2=omega**2, **modal, G=np.ascontiguousarray(p.G @ T), b_exc=T.T @ p.b_exc, b_N1=T.T @ p.b_N1,
        f_const=T.T @ p.f_const, out_rows=np.ascontiguousarray(p.out_rows @ T),
        bolt_rows=np.ascontiguousarray(p.bolt_rows @ T))
    return PlantModel(model.cfg, model.structure, params, model.Phi @ T, omega, model.reduced)


def _with_bolt_reference(model: PlantModel, F_N1: float) -> PlantParams:
    """The bolts' reference separations g_ref (docs/plant.md 1.4): the screws are tightened to
    their preloads F_N (the adaptive one to F_N1 [N], the stack at 0 V) in the assembled static
    state, so each bolt's force F_b = F_N + k_b (g_b - g_ref_b) equals its preload there. That state
    is the equilibrium of the preloads and the contact without the bolt springs (the spring terms
    vanish at g = g_ref); the constant k_b g_ref_b enters f_const."""
    p = model.params
    K_free = np.diag(p.omega2) - (p.bolt_rows.T * p.bolt_k) @ p.bolt_rows
    q, _, _ = static_equilibrium(model, F_N1, K=K_free)
    g_ref = p.bolt_rows @ q
    return p._replace(bolt_ref=g_ref, f_const=p.f_const + p.bolt_rows.T @ (p.bolt_k * g_ref))


def _with_quasi_static_loads(p: PlantParams) -> PlantParams:
    """p with n_dyn and the quasi-static modes' share of the step's predicted gaps per held load,
    gq_b = G_s diag(s2_s) b_s for b = b_exc, b_N1, f_const (s: the modes with dyn = 0; their s2 =
    (1 + theta) / omega^2 does not depend on the step, so the fallback substep shares them). The
    step reads these instead of the quasi-static columns of G (plant.newmark._substep). The
    modes are in ascending frequency, so the stepped ones come first."""
    n_dyn = int((p.dyn > 0).sum())
    if not (p.dyn[:n_dyn] > 0).all():
        raise ValueError("the stepped modes (dyn = 1) must come before the quasi-static ones")
    Gs = p.G[:, n_dyn:] * p.s2[n_dyn:]
    return p._replace(n_dyn=n_dyn, gq_exc=Gs @ p.b_exc[n_dyn:], gq_N1=Gs @ p.b_N1[n_dyn:],
                      gq_const=Gs @ p.f_const[n_dyn:])


def iwan_fractions(cfg: Config) -> dict[str, np.ndarray]:
    """Element stiffness and slip-limit fractions of the pairs' tangential law (plant.contact):
    iwan_k = k_i / k_t = 1/N, iwan_q = q_i / (mu f_n) = (1 + a (2 (i + 1/2)/N - 1)) / N with
    a = plant.interface.iwan_spread and N = iwan_elements; a = 0: one Jenkins element ([1], [1])."""
    i = cfg.plant.interface
    if i.iwan_spread == 0.0:
        return {"iwan_k": np.ones(1), "iwan_q": np.ones(1)}
    N = int(i.iwan_elements)
    return {"iwan_k": np.full(N, 1.0 / N),
            "iwan_q": (1.0 + i.iwan_spread * (2.0 * (np.arange(N) + 0.5) / N - 1.0)) / N}


def contact_forces(model: PlantModel, g: np.ndarray, w_old: np.ndarray):
    """Vectorised pair law over all pairs (design time): lambda (2p,), w_new (p N,), dlambda/dg (2p, 2p).
    An Iwan element is summed from its N Jenkins elements (k_i = iwan_k_i k_t, mu_i = iwan_q_i mu)."""
    p = model.params
    m = len(g)
    N = model.n_sliders
    lam, w_new, D = np.zeros(m), np.zeros(m // 2 * N), np.zeros((m, m))
    for j in range(m // 2):
        for i in range(N):
            ln, lt, wn, dnn, dtn, dtt = _jenkins_pair(g[2 * j], g[2 * j + 1], w_old[j * N + i], p.k_n[j],
                                                      p.k_t[j] * p.iwan_k[i], p.mu[j] * p.iwan_q[i])
            lam[2 * j], w_new[j * N + i] = ln, wn
            lam[2 * j + 1] += lt
            D[2 * j, 2 * j] = dnn
            D[2 * j + 1, 2 * j] += dtn
            D[2 * j + 1, 2 * j + 1] += dtt
    return lam, w_new, D


def static_equilibrium(model: PlantModel, F_N1: float, max_iter: int = 100, K: np.ndarray | None = None):
    """Static state under the screws: K q = f_const + b_N1 F_N1 + G^T lambda(G q, w = 0), with the
    modal stiffness K = diag(omega^2) (the bolted assembly) unless given.

    Newton from the all-closed, all-stuck linear solution. Returns (q, w, g).
    """
    p = model.params
    K = np.diag(model.omega**2) if K is None else K
    f = p.f_const + p.b_N1 * F_N1
    m = p.G.shape[0]
    k_all = np.zeros(m)
    k_all[0::2], k_all[1::2] = p.k_n, p.k_t
    q = np.linalg.solve(K + (p.G.T * k_all) @ p.G, f)
    w0 = np.zeros(m // 2 * model.n_sliders)
    for _ in range(max_iter):
        g = p.G @ q
        lam, w, D = contact_forces(model, g, w0)
        R = K @ q - f - p.G.T @ lam
        if np.max(np.abs(R)) <= 1e-10 * max(1.0, np.max(np.abs(f))):
            return q, w, g
        q = q - np.linalg.solve(K - p.G.T @ D @ p.G, R)
    raise RuntimeError(f"static equilibrium under the screws did not converge (F_N1 = {F_N1} N); "
                       "check the interface stiffnesses and screw positions")


def preloaded_pairs(model: PlantModel, F_N1: float | None = None) -> np.ndarray:
    """Boolean mask of the pairs the screws close (static equilibrium at F_N1 [N])."""
    x0 = model.initial_state(F_N1)
    return x0[model.state_slots()["g"]][0::2] < 0.0


def stuck_stiffness(model: PlantModel, pairs: np.ndarray | None = None) -> np.ndarray:
    """Modal stiffness with the contact linearised as stuck, k_n and k_t, at `pairs` (boolean
    mask; all pairs if None): diag(omega^2) + G^T K_c G [1/s^2]."""
    p = model.params
    mask = np.ones(model.n_pairs, bool) if pairs is None else np.asarray(pairs, bool)
    k_all = np.zeros(p.G.shape[0])
    k_all[0::2] = p.k_n * mask
    k_all[1::2] = p.k_t * mask
    return np.diag(p.omega2) + (p.G.T * k_all) @ p.G


def stuck_frequencies_hz(model: PlantModel, pairs: np.ndarray | None = None) -> np.ndarray:
    """Eigenfrequencies [Hz] with the contact linearised as stuck at `pairs`
    (``stuck_stiffness``). Rigid-body modes excluded."""
    lam = sla.eigvalsh(stuck_stiffness(model, pairs))
    f = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
    return f[f > 1e-3]
