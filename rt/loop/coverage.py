"""Which paths of the controller a stream of its outputs exercised: the coverage of a replay.

A bit-exact replay proves the controller equal only on the paths the log took. ``coverage``
reads them off the controller's outputs (``frictionrt.rt.loop.replay.COMMANDED`` names):

    law          the law's setpoint F_set [N] (before the supervisor) at F_min, strictly between
                 F_min and F_max (hysteresis: K_f u0; Lyapunov: the boundary layer
                 F_max |v_rel| / eps), at F_max; ``left_passive``: the controlled law
                 (hysteresis, Lyapunov) lifted F_set above F_min at least once
    tracking     ticks at the amplifier's limits (saturated +1: V_max, -1: V_min)
    supervisor   the fault codes seen (``frictionrt.rt.loop.supervisor`` codes, by name) with
                 their ticks, the ticks in the passive fallback, whether a fault latched

``replay`` (numba), ``replay --c`` and the export's golden vectors report it; ``replay
--require-coverage`` fails when ``left_passive`` is False.
"""
from __future__ import annotations

import numpy as np

CONTROLLED = ("hysteresis", "lyapunov")   # laws with a passive state to leave
FAULT_NAMES = {1: "sensor_nonfinite", 2: "sensor_range", 3: "sensor_stuck", 4: "force_disagree",
               5: "observer_divergence", 6: "command_nonfinite", 7: "tracking_error", 8: "amp_saturation",
               9: "overrun_burst"}


def coverage(law: str, F_min: float, F_max: float, out: dict[str, np.ndarray]) -> dict:
    """The coverage (module docstring) of the outputs ``out`` (name -> per-tick values) of the
    law ``law`` with limits F_min, F_max [N]."""
    F = np.asarray(out["F_set"])
    sat = np.asarray(out["saturated"])
    code = np.asarray(out["fault_code"]).astype(np.int64)
    passive = np.asarray(out["passive"]) != 0
    between = int(((F > F_min) & (F < F_max)).sum())
    at_max = int((F >= F_max).sum())
    codes = {FAULT_NAMES.get(int(c), str(int(c))): int((code == c).sum()) for c in np.unique(code) if c != 0}
    return {"ticks": int(len(F)), "law": law,
            "law_at_F_min": int((F <= F_min).sum()), "law_between": between, "law_at_F_max": at_max,
            "left_passive": (between + at_max > 0) if law in CONTROLLED else None,
            "saturated_high": int((sat > 0).sum()), "saturated_low": int((sat < 0).sum()),
            "fault_codes": codes, "passive_ticks": int(passive.sum()),
            "latched": bool((np.asarray(out["fault_latched"]) != 0).any())}


def coverage_problem(cov: dict) -> str | None:
    """What ``--require-coverage`` fails on, in one line, or None."""
    if cov["left_passive"] is False:
        return (f"coverage: the {cov['law']} law never left F_min in {cov['ticks']} ticks, so the replay does not "
                "test it; record a run that lifts it (a larger --amp, or a frequency nearer a resonance)")
    return None


def format_coverage(cov: dict) -> str:
    """Two lines for the replay's text output."""
    codes = ", ".join(f"{k} {v}" for k, v in cov["fault_codes"].items()) or "none"
    left = "" if cov["left_passive"] is None else f" (left F_min: {'yes' if cov['left_passive'] else 'NO'})"
    return (f"  coverage: law {cov['law']} at F_min {cov['law_at_F_min']}, between {cov['law_between']}, "
            f"at F_max {cov['law_at_F_max']} ticks{left}; saturated +{cov['saturated_high']} / -{cov['saturated_low']}\n"
            f"  supervisor: faults {codes}; passive {cov['passive_ticks']} ticks{', latched' if cov['latched'] else ''}")
