"""Eigenfrequency summaries of the plant (the ``frictionrt modes`` command)."""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from frictionrt.plant.fe_beam import U, W
from frictionrt.plant.model import PlantModel, build_plant, preloaded_pairs, stuck_frequencies_hz, stuck_stiffness
from frictionrt.plant.structure import adaptive_cone_pairs
from frictionrt.rt.common.config import Config, adaptive_screw, with_sets

N_BARE = 6  # bending modes of the bare cantilever reported
REDUCTION_TOL = 5e-3  # SPEC 2 "Reduction": reduced vs full stuck eigenfrequencies below 2 kHz


def bare_beam_bending_hz(model: PlantModel, beam: str, n_modes: int = N_BARE) -> np.ndarray:
    """First bending eigenfrequencies [Hz] of one beam alone (its clamps, no contact), full FE.

    Axial modes are told apart from bending modes by where their kinetic energy sits
    (u DOFs vs w DOFs).
    """
    sub = next(s for s in model.structure.subs if s.beam.name == beam)
    lam, V = sla.eigh(sub.K, sub.M)
    comp = sub.free % 3
    f = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
    ke = V * (sub.M @ V)
    bending = ke[comp == W].sum(axis=0) > ke[comp == U].sum(axis=0)
    return f[bending & (f > 1e-3)][:n_modes]


def adaptive_screw_k_T(model: PlantModel, F_N1: float | None = None) -> float:
    """Effective tangential stiffness k_T [N/m] at the adaptive screw: a unit pair of opposite
    tangential forces on the two surfaces there, divided into u_rel, in the model linearised
    about the preloaded state (closed pairs stuck)."""
    K = stuck_stiffness(model, preloaded_pairs(model, F_N1))
    b = model.Phi.T @ model.structure.u_rel_row  # modal load of the unit tangential force pair
    return float(1.0 / (b @ np.linalg.solve(K, b)))


def sliding_joint_hz(model: PlantModel, F_N1: float | None = None) -> np.ndarray:
    """Eigenfrequencies [Hz] of the preloaded model (closed pairs stuck) with the pairs in the
    adaptive screw's pressure cone free to slide (no tangential stiffness): the linear picture of
    the passive damper, where the joint at the adaptive screw slips through most of each cycle.
    The passive step-sine resonances lie 1-2.5 % below these (mode 3: 205.2 against 200.55 Hz at
    5 N; mode 4: 380.1 against 374.36 Hz; docs/plant.md 9), which is how tests and benchmarks place
    their excitation from the plant's own modes; ``frictionrt compare --mode`` finds the step-sine
    peak itself (docs/loop.md). Rigid-body modes excluded."""
    cone = adaptive_cone_pairs(model.cfg, model.structure.x_pairs)
    p = model.params
    closed = preloaded_pairs(model, F_N1)
    k_all = np.zeros(p.G.shape[0])
    k_all[0::2] = p.k_n * closed
    k_all[1::2] = p.k_t * (closed & ~cone)
    f = np.sqrt(np.maximum(sla.eigvalsh(np.diag(p.omega2) + (p.G.T * k_all) @ p.G), 0.0)) / (2 * np.pi)
    return f[f > 1e-3]


def passive_resonance_hz(cfg: Config, mode: int) -> float:
    """Where the passive damper's mode ``mode`` (1-based) resonates, from the model's own modes
    (``sliding_joint_hz`` at F_N1 = tracking.F_min_N), rounded to 0.1 Hz."""
    f = sliding_joint_hz(build_plant(cfg), cfg.tracking.F_min_N)
    return round(float(f[mode - 1]), 1)


def bare_beam_name(cfg: Config) -> str:
    """The beam whose bare bending modes ``modes`` reports: the interface's lower beam, or without an
    interface the first clamped beam."""
    if cfg.plant.interface.enabled:
        return cfg.plant.interface.lower
    clamped = [c.beam for c in cfg.plant.clamps]
    return next((b.name for b in cfg.plant.beams if b.name in clamped), cfg.plant.beams[0].name)


def modes_summary(cfg: Config, f_max_hz: float = 2000.0) -> dict:
    """Eigenfrequencies of the bare beam, the full and the Craig-Bampton model (contact stuck).

    Keys: bare_cantilever_hz (``bare_beam_name``), full_stuck_hz, reduced_stuck_hz (all pairs
    stuck, modes below f_max_hz), eig_resolution_rel (per such mode, the relative round-off of its
    frequency, eps lambda_max / (2 lambda_i) of the full model: docs/plant.md 6),
    preloaded_stuck_hz (only the pairs the screws close), sliding_joint_hz (those, with the
    adaptive screw's pairs sliding, at F_N1 = F_min: ``sliding_joint_hz``), n_dof_full,
    n_dof_reduced (the Craig-Bampton basis), n_stepped (the coordinates the plant step carries:
    docs/plant.md 2.7), closed_pairs, k_T_adaptive_N_per_m, contact (k_n, k_t, mu). Without an
    adaptive screw sliding_joint_hz and k_T_adaptive_N_per_m are None; without an interface
    contact is None too (and every list of frequencies the same beam's).
    """
    every_mode = with_sets(cfg, ["plant.condense_quasi_static=false"])   # the FE and Craig-Bampton models themselves
    full = build_plant(every_mode, reduced=False)
    red = build_plant(every_mode, reduced=True)
    f_full = stuck_frequencies_hz(full)
    f_red = stuck_frequencies_hz(red)
    n = int(np.sum(f_full < f_max_hz))
    # an eigenvalue lambda_i is known to ~eps lambda_max, its frequency to eps lambda_max / (2 lambda_i)
    resolution = np.finfo(float).eps * (f_full[-1] / f_full[:n]) ** 2 / 2
    closed = preloaded_pairs(red)
    f_pre = stuck_frequencies_hz(red, closed)
    adaptive = adaptive_screw(cfg) is not None
    f_sl = sliding_joint_hz(red, cfg.tracking.F_min_N) if adaptive else None
    itf = cfg.plant.interface
    return {
        "bare_cantilever_hz": [round(float(f), 4) for f in bare_beam_bending_hz(full, bare_beam_name(cfg))],
        "full_stuck_hz": [round(float(f), 4) for f in f_full[:n]],
        "reduced_stuck_hz": [round(float(f), 4) for f in f_red[:n]],
        "eig_resolution_rel": [float(f"{r:.3g}") for r in resolution],
        "preloaded_stuck_hz": [round(float(f), 4) for f in f_pre[f_pre < f_max_hz]],
        "sliding_joint_hz": None if f_sl is None else [round(float(f), 4) for f in f_sl[f_sl < f_max_hz]],
        "n_dof_full": int(full.n),
        "n_dof_reduced": int(red.n),
        "n_stepped": int(build_plant(cfg).n),
        "n_pairs": int(red.n_pairs),
        "closed_pairs": [int(j) for j in np.nonzero(closed)[0]],
        "k_T_adaptive_N_per_m": float(f"{adaptive_screw_k_T(red):.6g}") if adaptive else None,
        "contact": {"k_n_area": itf.k_n_area, "k_t_area": itf.k_t_area, "mu": itf.mu,
                    "pitch_m": itf.pitch_m} if itf.enabled else None,
    }


def format_summary(s: dict) -> str:
    """``modes_summary`` as the table ``frictionrt modes`` prints (frequencies [Hz])."""
    sliding = s["sliding_joint_hz"] or []   # None: no adaptive screw
    lines = [f"bare cantilever (bending) [Hz]: {', '.join(f'{f:.2f}' for f in s['bare_cantilever_hz'])}",
             f"{'mode':>4} {'full stuck [Hz]':>16} {'reduced [Hz]':>13} {'error [%]':>10} {'preloaded [Hz]':>15} "
             f"{'adaptive joint sliding [Hz]':>28}"]
    for k, (a, r) in enumerate(zip(s["full_stuck_hz"], s["reduced_stuck_hz"])):
        pre = s["preloaded_stuck_hz"][k] if k < len(s["preloaded_stuck_hz"]) else float("nan")
        sl = sliding[k] if k < len(sliding) else float("nan")
        lines.append(f"{k + 1:>4} {a:>16.2f} {r:>13.2f} {100 * (r - a) / a:>10.3f} {pre:>15.2f} {sl:>28.2f}")
    k_T = s["k_T_adaptive_N_per_m"]
    err = [abs(r - a) / a for a, r in zip(s["full_stuck_hz"], s["reduced_stuck_hz"])]
    if err and max(err) > REDUCTION_TOL:
        k = int(np.argmax(err))
        res = s["eig_resolution_rel"][k]
        why = (f"but within what the eigensolver resolves on this mesh ({100 * res:.2g} %: eps x the largest "
               "eigenvalue, which grows as the elements shrink); neither figure is better: use elements of 2.5 mm "
               "or more (docs/plant.md 6, 'Contact pitch')" if err[k] <= 2 * res else
               "(the reduction): raise plant.cb_cutoff_hz or step the full model (--set plant.reduced=false)")
        lines.append(f"warning: reduced and full differ by {100 * err[k]:.3f} % on mode {k + 1}, more than SPEC's "
                     f"{100 * REDUCTION_TOL:g} % {why}")
    lines.append(f"DOFs: full {s['n_dof_full']}, reduced {s['n_dof_reduced']}, stepped {s['n_stepped']}; "
                 f"pairs {s['n_pairs']}, "
                 f"closed by the screws {s['closed_pairs']}; "
                 + ("no adaptive screw" if k_T is None else f"k_T at the adaptive screw {k_T:.3g} N/m"))
    return "\n".join(lines)
