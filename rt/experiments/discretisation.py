"""How far the plant's discretisation moves each claim's margin (docs/experiments.md, "The
discretisation error beside each claim").

The claims' margins (rt.experiments.claims) are measured on a plant whose contact pitch, element
length and time step are numerical choices (docs/plant.md 6). The estimate is Richardson's, once in
space and once in time, from the default's margin M and two more runs of the same plan:

- ``coarser``: the pitch and the element length doubled (half the contact points, cheaper than the
  default), margin M_coarse, the joint's observed order p in the pitch;
- ``halved_step``: twice the plant's substeps (the step halved; one substep is the coarsest, so the
  step is refined where the pitch is coarsened), margin M_half, the step's observed order q:

    M_converged - M  ~  (M - M_coarse) / (2^p - 1)  +  (M_half - M) 2^q / (2^q - 1)   (``refined_shift``)

``ORDER`` = ``STEP_ORDER`` = 1: the frequencies and, off the slip thresholds, the damping converge at
about first order in the pitch (docs/plant.md 6.2), and the plant step's FRF error at about first
order after the first halving (docs/plant.md 6.6); p = q = 1 is the order for which each term is
largest among orders >= 1. The two terms are the space and time parts of the error to first order;
their signs differ where the step's and the pitch's errors cancel in the default.

The claims on the impulse test (C2; C1 is a model input) are not estimated but measured: the
impulse test is cheap enough to run on the refined plant itself (``refined``: the pitch and the
element length halved, four times the substeps; ``refined_impulse_margins``), and their shift is
M_refined - M. The damping it rests on converges in no order in the pitch where the hammer sits on
a slip threshold (docs/plant.md 6.2), where Richardson's estimate fails (docs/experiments.md).

The coarse run's, the halved step's and the refined impulse test's margins are stored per
configuration and plan (``COARSE_STORE``, keyed by ``record_key``: the resolved configuration, the
plan, the kernel version), so a run of a stored configuration pays for the default alone; another
configuration runs them itself.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from enum import Enum
from pathlib import Path

from frictionrt.rt.common.config import Config, refined_sets, to_dict, with_sets
from frictionrt.rt.common.kernel_version import KERNEL_VERSION
from frictionrt.rt.experiments.claims import MARGIN_UNIT, claim_c2, verdict

COARSENING = 2.0
ORDER = 1.0
STEP_ORDER = 1.0
COARSE_STORE = Path(__file__).with_name("coarse_margins.json")


class ErrorEstimate(str, Enum):
    """Where a reproduction's coarse margins come from."""
    AUTO = "auto"      # the stored record of this configuration and plan, else a coarse run
    RUN = "run"        # always run the coarse plan
    NONE = "none"      # no estimate: each verdict from its margin's sign


def coarser(cfg: Config, factor: float = COARSENING) -> Config:
    """``cfg`` with the contact pitch and the element length multiplied by factor (the end
    refinement kept: the ends' pitch grows with it); the same physical model (contact per area)."""
    p = cfg.plant
    return with_sets(cfg, [f"plant.interface.pitch_m={p.interface.pitch_m * factor!r}",
                           f"plant.element_length_m={p.element_length_m * factor!r}"])


def halved_step(cfg: Config) -> Config:
    """``cfg`` with twice the plant's substeps (the step h / 2); the same model and contact layout."""
    return with_sets(cfg, [f"plant.substeps={2 * cfg.plant.substeps}"])


def refined(cfg: Config) -> Config:
    """``cfg`` with the pitch and the element length halved and four times the substeps
    (``refined_sets(cfg, 2)``): the refined plant of docs/plant.md 6."""
    return with_sets(cfg, refined_sets(cfg, 2))


def refined_impulse_margins(cfg: Config, fn1_n: float) -> dict[str, float]:
    """{"C2": margin} of the impulse test at F_N1 = fn1_n [N] on the refined plant (``refined``)."""
    from frictionrt.plant.impulse import impulse_test
    from frictionrt.plant.model import build_plant
    imp = impulse_test(build_plant(refined(cfg)), fn1_n)
    zeta_bare = {m: float(cfg.plant.modal_damping) for m in imp.modes}
    return {"C2": claim_c2({m: float(z) for m, z in zip(imp.modes, imp.damping_ratio)}, zeta_bare)["margin"]}


def refined_shift(margin: float | None, coarse: float | None, order: float = ORDER,
                  half_step: float | None = None, step_order: float = STEP_ORDER) -> float | None:
    """Richardson's estimate of M_converged - M [the margin's unit] from the default's margin M,
    the coarse discretisation's (the pitch's term) and, where given, the halved step's (the step's
    term; module docstring); None for a claim without a margin, NaN where any given margin is not
    finite."""
    if margin is None or coarse is None:
        return None
    given = [margin, coarse] + ([] if half_step is None else [half_step])
    if not all(math.isfinite(x) for x in given):
        return math.nan
    shift = (margin - coarse) / (COARSENING ** order - 1.0)
    if half_step is not None:
        shift += (half_step - margin) * 2.0 ** step_order / (2.0 ** step_order - 1.0)
    return shift


def margins(claims: dict) -> dict[str, float | None]:
    """claim -> margin of a report's claims dict."""
    return {c: v.get("margin") for c, v in claims.items()}


def annotate(claims: dict, coarse: dict[str, float | None] | None, source: str,
             refined_margins: dict[str, float] | None = None,
             half_step: dict[str, float | None] | None = None) -> dict:
    """The claims dict with, per claim, ``refined_shift`` (None: not estimated; the refined
    margin's difference where ``refined_margins`` has the claim, else Richardson's from the coarse
    margins and, where ``half_step`` is given, the halved step's), ``margin_unit``, ``verdict``
    (claims.Verdict's value) and ``error_estimate`` = source ("refined" where the refined plant's
    own margin decided)."""
    out = {}
    for c, v in claims.items():
        m, how = v.get("margin"), source
        if refined_margins and c in refined_margins and m is not None:
            r = refined_margins[c]
            shift, how = (r - m if math.isfinite(r) and math.isfinite(m) else math.nan), f"refined ({source})"
        else:
            shift = (refined_shift(m, coarse.get(c), half_step=None if half_step is None else half_step.get(c))
                     if coarse is not None else None)
        out[c] = v | {"margin_unit": MARGIN_UNIT.get(c), "refined_shift": shift,
                      "verdict": verdict(m, shift, v["holds"]).value, "error_estimate": how}
    return out


def record_key(cfg: Config, plan) -> str:
    """Hex digest of the resolved configuration, the plan and the kernel version."""
    doc = {"config": to_dict(cfg), "plan": dataclasses.asdict(plan), "kernel_version": KERNEL_VERSION}
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:20]


def stored(cfg: Config, plan, path: Path = COARSE_STORE) -> tuple[dict | None, dict | None, dict | None]:
    """(estimator -> claim -> coarse margin, claim -> refined margin, estimator -> claim -> the
    halved step's margin) of the stored record of (cfg, plan); None for each part it lacks."""
    try:
        records = json.loads(path.read_text())
    except (OSError, ValueError):
        return None, None, None
    rec = records.get(record_key(cfg, plan), {})
    return rec.get("coarse_margins"), rec.get("refined_margins"), rec.get("half_step_margins")


def store(cfg: Config, plan, coarse: dict, note: str, path: Path = COARSE_STORE,
          refined_margins: dict | None = None, half_step: dict | None = None) -> None:
    """Add (cfg, plan)'s coarse margins (estimator -> claim -> margin), refined impulse margins
    (claim -> margin) and the halved step's margins (estimator -> claim -> margin) to the record at
    path."""
    try:
        records = json.loads(path.read_text())
    except (OSError, ValueError):
        records = {}
    records[record_key(cfg, plan)] = {"note": note, "coarse_margins": coarse, "refined_margins": refined_margins,
                                      "half_step_margins": half_step}
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(records, indent=1, sort_keys=True) + "\n")
    tmp.replace(path)
