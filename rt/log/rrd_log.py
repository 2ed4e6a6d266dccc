"""Run logs as rerun .rrd recordings (rerun-sdk 0.41), sent column-wise in blocks.

The recording (its own ``rr.RecordingStream``, never the global one; nothing is spawned) holds:

    /<owner>          one entity per topic of the MCAP log (/rt, /sensors, ..., /plant), its
                      signals as one multi-series ``rr.Scalars`` row per tick in column order; a
                      static ``rr.SeriesLines`` names the series by their ROS 2 fields (the MCAP
                      field names, ``frictionrt.rt.log.registry.ros2_field``: /plant f_n1) and a static
                      ``unit`` (AnyValues, one unit per series) gives their units
    /hysteresis       ``rr.Points2D`` per tick at (u_rel [um], -F_t [N]) where
                      F_t = sum_j f_t_j is the interface's total tangential (friction) force: the
                      plant logs no tangential force at the adaptive screw itself, and u_rel is
                      the slip there. y is -F_t because rerun's 2-D view points y down, so the
                      loop appears with positive force up. Only if u_rel and f_t_* are logged.
    timelines         "t": duration (k * 10**9) // rate_hz [ns] (the MCAP log_time less the
                      run's start, exact); "tick": sequence k; "utc": timestamp, the MCAP log_time
                      (the run's UTC start plus t), when the start is known
    properties        "frictionrt": the caller's metadata strings (configuration TOML, versions,
                      seed, ...), if given

One entity per topic, not per signal: each entity costs its own row ids and timelines per row,
so 85 entities made the .rrd 43.5 MB per simulated second (3.3 times the MCAP file); 6 make it
about as large as the MCAP file (docs/data-format.md).

The default blueprint (embedded with ``blueprint=True``) has the panels of ``frictionrt.rt.log.views``: a
"damper" tab with "F_N1 setpoint vs measured" (the other series of its entities hidden) above
the friction hysteresis, and one time-series tab per owner.

``write_frf_rrd`` writes step-sine and sweep FRFs (``frictionrt frf --rrd``) as their own recording:
|H| [dB], phase and force amplitude per law, amplitude and direction against a frequency timeline.

The file is written as ``NAME.rrd.part`` and renamed onto ``NAME.rrd`` on close; an exception
inside ``with RrdLogWriter(...)`` still closes (and renames) the file.
"""
from __future__ import annotations

import os
import uuid
from pathlib import Path
from typing import Self

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from frictionrt.rt.log.mcap_log import (check_block, check_owners, check_rate, part_path, start_time_ns, tick_runs,
                             tick_time_ns)
from frictionrt.rt.log.registry import field_names
from frictionrt.rt.log.views import HYSTERESIS_WINDOW_S, SETPOINT_SIGNALS, SETPOINT_TITLE, hysteresis_columns, topic_columns

def default_blueprint(signals) -> rrb.Blueprint:
    """Setpoint vs measured F_N1 and the friction hysteresis, then one time-series tab per owner."""
    setpoint = {}   # entity -> visible_series of its series
    for entity, cols in topic_columns(signals):
        shown = [signals[c][0] in SETPOINT_SIGNALS for c in cols]
        if any(shown):
            setpoint[entity] = shown
    damper = [rrb.TimeSeriesView(origin="/", contents=list(setpoint), name=SETPOINT_TITLE,
                                 overrides={e: rr.SeriesLines.from_fields(visible_series=v)
                                            for e, v in setpoint.items()})]
    if hysteresis_columns(signals) is not None:
        window = rrb.VisibleTimeRange("t", start=rrb.TimeRangeBoundary.cursor_relative(seconds=-HYSTERESIS_WINDOW_S),
                                      end=rrb.TimeRangeBoundary.cursor_relative())
        damper.append(rrb.Spatial2DView(origin="/hysteresis", name="friction hysteresis: F_t [N] up vs u_rel [um]",
                                        time_ranges=window))
    return rrb.Blueprint(rrb.Tabs(rrb.Vertical(*damper, name="damper"),
                                  *[rrb.TimeSeriesView(origin=e, name=e[1:]) for e, _ in topic_columns(signals)]))


class RrdLogWriter:
    """Writes a run's log to an .rrd file in blocks of ticks (see the module docstring).

    Parameters
    ----------
    path : the .rrd file; written as ``path.part`` and renamed on close.
    signals : (name, unit, owner) per log column.
    rate_hz : tick rate [Hz], a whole number (t_k = k / rate_hz).
    metadata : strings sent as the recording property "frictionrt"; its "start_utc" is the run's UTC start.
    start_ns : the run's UTC start [ns since 1970] (default: from metadata's "start_utc"); if known
        (> 0), the timeline "utc" holds start_ns + t.
    blueprint : embed ``default_blueprint(signals)``.
    app_id : rerun application id (blueprints are remembered per application).
    """

    def __init__(self, path: str | os.PathLike, signals, rate_hz: float, *, metadata: dict[str, str] | None = None,
                 start_ns: int | None = None, blueprint: bool = True, app_id: str = "frictionrt"):
        self.path = Path(path)
        self.start_ns = start_time_ns(metadata or {}) if start_ns is None else int(start_ns)
        self.signals = tuple(tuple(s) for s in signals)
        self.rate_hz = check_rate(self.path, rate_hz)
        check_owners(self.path, self.signals)
        self._entities = topic_columns(self.signals)
        fields = field_names(self.signals)
        self._hysteresis = hysteresis_columns(self.signals)
        self._part = part_path(self.path)
        self._rec = rr.RecordingStream(app_id, recording_id=uuid.uuid4())
        self._rec.save(self._part, default_blueprint=default_blueprint(self.signals) if blueprint else None)
        if metadata:
            self._rec.send_property("frictionrt", rr.AnyValues(**metadata))
        for entity, cols in self._entities:
            self._rec.log(entity, rr.SeriesLines(names=[fields[c] for c in cols]),
                          rr.AnyValues(unit=[self.signals[c][1] for c in cols]), static=True)
        self._open = True
        self._k_next = 0

    def write_block(self, k0: int, block: np.ndarray) -> None:
        """Append ticks k0 .. k0 + n - 1; block is float64 (n, n_sig), row i = tick k0 + i.

        Ticks must increase from block to block; a gap (a dropped block) is allowed."""
        if not self._open:
            raise ValueError(f"{self.path}: write_block after close")
        k0, n = check_block(self.path, k0, block, len(self.signals), self._k_next)
        if n == 0:
            return
        k = np.arange(k0, k0 + n, dtype=np.int64)
        t = tick_time_ns(k, self.rate_hz)
        index = [rr.TimeColumn("t", duration=t.astype("timedelta64[ns]")), rr.TimeColumn("tick", sequence=k)]
        if self.start_ns > 0:
            index.append(rr.TimeColumn("utc", timestamp=(self.start_ns + t).astype("datetime64[ns]")))
        for entity, cols in self._entities:
            self._rec.send_columns(entity, indexes=index, columns=rr.Scalars.columns(scalars=block[:, cols]),
                                   strict=True)
        if self._hysteresis is not None:
            u, ft = self._hysteresis
            with np.errstate(over="ignore", invalid="ignore"):  # a diverged run plots as inf
                xy = np.column_stack([1e6 * block[:, u], -block[:, ft].sum(axis=1)])
            self._rec.send_columns("/hysteresis", indexes=index, columns=rr.Points2D.columns(positions=xy),
                                   strict=True)
        self._k_next = k0 + n

    def close(self) -> None:
        """Flush, finish the file and rename it onto ``path``. Idempotent."""
        if not self._open:
            return
        self._open = False
        self._rec.flush()
        self._rec.disconnect()  # drops the file sink: footer written, file closed
        os.replace(self._part, self.path)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()  # also on an exception: the ticks sent so far stay a valid recording


def write_rrd(path: str | os.PathLike, signals, log: np.ndarray, rate_hz: float, *, k0: int = 0,
              k: np.ndarray | None = None, blueprint: bool = True, app_id: str = "frictionrt",
              metadata: dict[str, str] | None = None, start_ns: int | None = None, block_ticks: int = 21000) -> None:
    """Write a whole log (float64 (ticks, n_sig), row i = tick k0 + i, or tick k[i] if the
    increasing int64 ticks k are given: gaps allowed) to ``path`` as .rrd, in blocks of at most
    ``block_ticks`` consecutive ticks (see ``RrdLogWriter``)."""
    k = k0 + np.arange(len(log), dtype=np.int64) if k is None else np.asarray(k, dtype=np.int64)
    with RrdLogWriter(path, signals, rate_hz, metadata=metadata, start_ns=start_ns, blueprint=blueprint,
                      app_id=app_id) as w:
        for a, b in tick_runs(k):
            for i in range(a, b, block_ticks):
                w.write_block(int(k[i]), log[i:min(b, i + block_ticks)])


def layout_path(rrd: str | os.PathLike) -> Path:
    """Where the Foxglove layout of a recording goes: NAME.foxglove.json beside NAME.rrd."""
    rrd = Path(rrd)
    return rrd.with_name((rrd.name[:-4] if rrd.name.endswith(".rrd") else rrd.name) + ".foxglove.json")


def mcap_to_rrd(src: str | os.PathLike, dst: str | os.PathLike, *, overwrite: bool = False) -> dict:
    """Convert an MCAP log or measurement (``frictionrt.rt.log.mcap_log.read_mcap``) to an .rrd recording with
    the default blueprint, as ``simulate --out`` writes it: the columns of the topics present in
    the file only (a measurement with /sensors alone gets /sensors entities and tab), ticks and
    gaps as in the file, the file's UTC start (timeline "utc"), the "frictionrt" metadata record as
    the recording property; and beside it, as ``simulate --out`` does, the Foxglove layout of the
    same panels (``layout_path(dst)``: NAME.foxglove.json for NAME.rrd).

    ``dst`` is written under a temporary name in its folder and then renamed: an existing
    ``dst`` (or layout) is replaced only if ``overwrite``, never left half-written. ValueError naming
    the file on any problem. Returns {input, output, foxglove_layout, ticks, first_tick, last_tick,
    topics, entities}."""
    from frictionrt.rt.log.mcap_log import check_conversion, read_mcap
    from frictionrt.rt.log.views import write_foxglove_layout
    src, dst = Path(src), Path(dst)
    hint = None if overwrite else "give another name with -o or pass --force to replace it"
    check_conversion(src, dst, hint)
    layout = layout_path(dst)
    if hint is not None and layout.exists():
        raise ValueError(f"{layout}: the output exists; {hint}")
    rec = read_mcap(src)
    cols = [c for c, (_, _, o) in enumerate(rec.signals) if f"/{o}" in rec.topics]
    signals = [rec.signals[c] for c in cols]
    tmp = dst.with_name(dst.name + ".inspect.tmp")   # its .part is never a file of the user's
    try:
        write_rrd(tmp, signals, rec.log[:, cols], rec.rate_hz, k=rec.k, metadata=rec.metadata or None,
                  start_ns=rec.start_ns)
        write_foxglove_layout(layout, signals)
        os.replace(tmp, dst)
    finally:
        tmp.unlink(missing_ok=True)
    return {"input": str(src), "output": str(dst), "foxglove_layout": str(layout), "ticks": len(rec.k),
            "first_tick": int(rec.k[0]) if len(rec.k) else None, "last_tick": int(rec.k[-1]) if len(rec.k) else None,
            "topics": list(rec.topics), "entities": [e for e, _ in topic_columns(signals)]}


FRF_TIMELINE = "freq_mHz"   # rerun plots series against a timeline: the frequency in whole mHz


def frf_entity(law: str, amp_n: float, direction: str) -> str:
    """/frf/<law>_<amp>N_<direction>, e.g. /frf/lyapunov_5N_up."""
    return "/frf/" + rr.escape_entity_path_part(f"{law}_{amp_n:g}N_{direction}")


def write_series_rrd(path: str | os.PathLike, app_id: str, series, views, *, metadata: dict[str, str] | None = None,
                     static: dict | None = None) -> None:
    """A recording of whole curves, sent column-wise: ``series`` = [(entity, rr.TimeColumn, y)],
    ``views`` the blueprint's tabs or containers (embedded), ``static`` {entity: archetype} logged
    once (e.g. an rr.TextDocument), ``metadata`` the "frictionrt" property strings. Written as
    ``path.part``, renamed when complete."""
    path = Path(path)
    part = part_path(path)
    rec = rr.RecordingStream(app_id, recording_id=uuid.uuid4())
    rec.save(part, default_blueprint=rrb.Blueprint(*views))
    try:
        if metadata:
            rec.send_property("frictionrt", rr.AnyValues(**metadata))
        for entity, archetype in (static or {}).items():
            rec.log(entity, archetype, static=True)
        for entity, index, y in series:
            rec.send_columns(entity, indexes=[index], columns=rr.Scalars.columns(scalars=np.asarray(y, float)),
                             strict=True)
        rec.flush()
    finally:
        rec.disconnect()
    os.replace(part, path)


def freq_index(freq_hz: np.ndarray) -> rr.TimeColumn:
    """The timeline "freq_mHz" at the frequencies ``freq_hz`` [Hz] (increasing)."""
    return rr.TimeColumn(FRF_TIMELINE, sequence=np.round(1e3 * np.asarray(freq_hz)).astype(np.int64))


def write_frf_rrd(path: str | os.PathLike, results, metadata: dict[str, str] | None = None) -> None:
    """Step-sine or sweep FRFs (``frictionrt.rt.experiments.stepsine.StepSineResult``) as an .rrd with its blueprint:
    per result, /frf/<law>_<amp>N_<dir>/magnitude_dB (20 log10 |H| [dB re 1 (m/s^2)/N]) and
    /phase_deg on the timeline "freq_mHz" (the frequency in whole mHz, so rerun's time-series
    views plot them against frequency), and /force_N (the measured force amplitude, to see the
    amplitude control hold). Written as ``path.part``, renamed when complete."""
    entities = [frf_entity(r.law, r.amp_n, r.direction) for r in results]
    views = [rrb.TimeSeriesView(origin="/frf", contents=[f"{e}/{leaf}" for e in entities], name=title)
             for leaf, title in (("magnitude_dB", "|H| [dB re 1 (m/s^2)/N] vs f [mHz]"),
                                 ("phase_deg", "phase [deg] vs f [mHz]"), ("force_N", "force amplitude [N]"))]
    series = []
    for r, e in zip(results, entities):
        order = np.argsort(r.freq_hz)
        index = freq_index(r.freq_hz[order])
        series += [(f"{e}/{leaf}", index, y) for leaf, y in (
            ("magnitude_dB", 20.0 * np.log10(r.H_abs[order])), ("phase_deg", np.degrees(r.phase_rad[order])),
            ("force_N", r.F_amp[order]))]
    write_series_rrd(path, "frictionrt-frf", series, [rrb.Vertical(*views)], metadata=metadata)
