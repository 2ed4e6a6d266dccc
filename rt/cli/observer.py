"""``frictionrt observer``: the observer's design (observer.kalman): kept modes, Kalman gain, eigenvalues."""
from __future__ import annotations

import argparse
import json

from frictionrt.rt.cli.common import fail


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``observer`` (parents: frictionrt's --config/--set parser)."""
    o = sub.add_parser("observer", parents=parents, help="observer design: kept modes, Kalman gain, eigenvalues",
                       description="Design the nonlinear observer from the configuration (docs/observer.md): the "
                                   "simplified linear model (damper tied at the normal screw, normal springs "
                                   "around the adaptive screw at observer.spring_scale k_n_area), its kept modes [Hz], the Kalman gain (dlqe on the "
                                   "exact ZOH discretisation), and the largest eigenvalue modulus of the discrete "
                                   "observer, without friction and linearised with it at F_max (implicit, as run, "
                                   "and explicit, to show why it is implicit).")
    o.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    return o


def cmd_observer(cfg, args) -> int:
    from frictionrt.observer.kalman import design_observer
    try:
        d = design_observer(cfg).summary(cfg.tracking.F_max_N)
    except ValueError as exc:
        return fail(str(exc))
    d["spring_scale"] = cfg.observer.spring_scale
    if args.json:
        print(json.dumps(d))
        return 0
    print(f"observer: {d['n_states']} states, modes [Hz]: {', '.join(f'{f:.1f}' for f in d['modes_hz'])}")
    xs = lambda v: "[" + ", ".join(f"{x:.4g}" for x in v) + "]"
    print(f"  tied at x = {xs(d['x_tied_m'])} m, normal springs at x = {xs(d['x_springs_m'])} m "
          f"(x {d['spring_scale']:g} k_n_area), zeta {d['zeta']:g}, "
          f"static correction D_u {d['D_u_m_per_n']:.3e} m/N")
    print(f"  Kalman (dlqe): Q = diag{tuple(d['Q_n2'])} N^2, R = {d['R_m2_s2']:.3g} (m/s)^2; "
          f"|M| {d['gain_norm_filter']:.3g}, |L| {d['gain_norm_predictor']:.3g}")
    print(f"  max |eig| discrete: {d['max_abs_eig_discrete']:.7f} (no friction), "
          f"{d['max_abs_eig_discrete_friction_fmax']:.7f} (friction at F_max = {d['F_max_n']:g} N, implicit), "
          f"{d['max_abs_eig_discrete_friction_fmax_explicit']:.4f} (explicit ZOH would be)")
    return 0

