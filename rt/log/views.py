"""The panels a run log is shown with, one definition for rerun and Foxglove.

    damper tab      "F_N1 setpoint vs measured": the law's F_set, the prefiltered setpoint
                    F_set_filtered, the true F_N1, the strain-gauge and force-cell readings
                    F_strain, F_cell (whichever are logged); "friction hysteresis": the
                    interface's tangential forces against the slip u_rel at the adaptive
                    screw, the last HYSTERESIS_WINDOW_S before the time cursor
    one tab per     every signal of the topic against time
    topic

``frictionrt.rt.log.rrd_log.default_blueprint`` builds them as a rerun blueprint (the hysteresis as points of
(u_rel [um], -sum_j f_t_j [N])); ``foxglove_layout`` as a Foxglove layout (JSON, Plot panels with
message paths such as ``/plant.f_n1``; the hysteresis as one x-y curve per contact pair j,
f_t_j [N] against u_rel [m], since a layout cannot sum fields). ``frictionrt simulate --out BASE``
writes the layout to ``BASE.foxglove.json`` beside the log (docs/recipes/inspect-a-run.md).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from frictionrt.rt.log.mcap_log import OWNERS, part_path
from frictionrt.rt.log.registry import field_names

SETPOINT_SIGNALS = ("F_set", "F_set_filtered", "F_N1", "F_strain", "F_cell")
SETPOINT_TITLE = "F_N1 setpoint vs measured"
HYSTERESIS_TITLE = "friction hysteresis: F_t [N] vs u_rel"
HYSTERESIS_WINDOW_S = 0.02   # [s] of the hysteresis view before the time cursor (4.5 periods at 224 Hz)


def hysteresis_columns(signals) -> tuple[int, np.ndarray] | None:
    """(u_rel column, f_t_* columns) of the plant, or None if either is not logged."""
    cols = {(o, n): c for c, (n, _, o) in enumerate(signals)}
    u = cols.get(("plant", "u_rel"))
    ft = [c for (o, n), c in cols.items() if o == "plant" and n.startswith("f_t_")]
    return None if u is None or not ft else (u, np.array(ft, dtype=np.int64))


def topic_columns(signals) -> list[tuple[str, np.ndarray]]:
    """(topic /<owner>, its log columns) per owner with signals, in OWNERS order."""
    return [(f"/{o}", np.array([c for c, s in enumerate(signals) if s[2] == o], np.int64))
            for o in OWNERS if any(s[2] == o for s in signals)]


def _plot(title: str, paths: list[str], x_path: str | None = None, window_s: float | None = None) -> dict:
    """A Foxglove Plot panel's configuration: the message paths against the log time, or
    against x_path (an x-y plot), over the last window_s [s] if given."""
    cfg = {"title": title, "paths": [{"value": p, "enabled": True, "timestampMethod": "receiveTime"} for p in paths],
           "showLegend": True, "legendDisplay": "floating", "showXAxisLabels": True, "showYAxisLabels": True,
           "isSynced": True, "xAxisVal": "timestamp"}
    if x_path is not None:
        cfg.update(xAxisVal="custom", xAxisPath={"value": x_path, "enabled": True})
    if window_s is not None:
        cfg["followingViewWidth"] = window_s
    return cfg


def _stack(ids: list[str]):
    """A Foxglove mosaic of panel ids, one above the other."""
    if len(ids) == 1:
        return ids[0]
    return {"direction": "column", "first": ids[0], "second": _stack(ids[1:]),
            "splitPercentage": 100 / len(ids)}


def foxglove_layout(signals) -> dict:
    """The Foxglove layout of a log with these (name, unit, owner) signals (module docstring)."""
    fields = field_names(signals)
    path = {n: f"/{o}.{f}" for (n, _, o), f in zip(signals, fields)}
    panels = {"Plot!setpoint": _plot(SETPOINT_TITLE, [path[n] for n in SETPOINT_SIGNALS if n in path])}
    hyst = hysteresis_columns(signals)
    if hyst is not None:
        u, ft = hyst
        panels["Plot!hysteresis"] = _plot(HYSTERESIS_TITLE, [path[signals[c][0]] for c in ft],
                                          x_path=path[signals[u][0]], window_s=HYSTERESIS_WINDOW_S)
    tabs = [{"title": "damper", "layout": _stack(list(panels))}]
    for topic, cols in topic_columns(signals):
        pid = f"Plot!{topic[1:]}"
        panels[pid] = _plot(topic[1:], [path[signals[c][0]] for c in cols])
        tabs.append({"title": topic[1:], "layout": pid})
    panels["Tab!main"] = {"activeTabIdx": 0, "tabs": tabs}
    return {"configById": panels, "globalVariables": {}, "userNodes": {}, "playbackConfig": {"speed": 1.0},
            "layout": "Tab!main"}


def write_foxglove_layout(path: str | os.PathLike, signals) -> Path:
    """Write ``foxglove_layout(signals)`` to ``path`` (as ``path.part``, renamed when complete)."""
    path = Path(path)
    part = part_path(path)
    part.write_text(json.dumps(foxglove_layout(signals), indent=1) + "\n")
    os.replace(part, path)
    return path
