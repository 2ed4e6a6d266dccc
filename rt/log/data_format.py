"""The measurement format (docs/data-format.md): what a run log or a measurement must carry, and
a validator that names what is missing or wrong.

A file is an MCAP log in the layout of ``frictionrt.rt.log.mcap_log`` (ROS 2 profile, topics per owning
package, ros2msg schemas of stamp, tick and the signals' ROS 2 fields, CDR messages, one message
per tick at log_time = start_ns + (k 10^9) // rate_hz ns) with the metadata records "signals"
(the layout; optional, with defaults), "test" (what was done: ``TEST_KEYS``) and, for the
project's own runs, "frictionrt" (configuration, law, estimator, seed, versions, command line).

``SIGNALS`` (``frictionrt.rt.log.registry``) is the registry of every signal the format knows.
tests/test_data_format.py checks it against the loop's own signal list (``frictionrt.rt.loop.build.loop_signals``)
in both directions and checks that the tables of docs/data-format.md are ``signal_table()``,
``required_table()`` and ``keys_table()`` verbatim (``python -m frictionrt.rt.log.data_format`` prints them).

``validate(path)`` returns the list of ``Problem`` s (empty: valid) and raises ValueError only
for a file that cannot be read at all (not MCAP, truncated, corrupt).
"""
from __future__ import annotations

import json
import math
import struct
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import zstandard
from mcap.exceptions import McapError
from mcap.reader import make_reader

from frictionrt.rt.common.config import require_adaptive_screw
from frictionrt.rt.log.mcap_log import (MAX_TICK, Topic, check_framing, chunk_messages, iter_messages, file_topics,
                         parse_schema, payload_rows, tick_time_ns, ticks_of_times)
from frictionrt.rt.log.registry import SIGNALS, entry_of, field_type, lower_rule, ros2_field



REQUIRED = ("F_exc", "a_tip_meas", "a_frf_meas", "v_tip_meas", "F_strain", "F_cell", "V_a", "i")
"""Signals every file must carry (run log or measurement)."""
SETPOINTS = ("F_set", "F_set_filtered", "V_cmd")
"""Required too when the test record names a control law (law != "none")."""

KINDS = ("impulse", "step-sine", "sweep", "free run", "actuator")
LAWS = ("passive", "hysteresis", "lyapunov", "none")
TEST_KEYS = (
    ("kind", "string", "one of: " + ", ".join(KINDS) + " (actuator: voltage command only, no excitation force)"),
    ("excitation_x_m", "float [m]", "x of the excitation point on the main beam (from the clamp)"),
    ("sensor_positions_m", "JSON object", "x [m] of each sensor by its field name, e.g. "
     '{"a_tip_meas": 0.765, "a_frf_meas": 0.45, "F_strain": 0.615, "F_cell": 0.615}; every acceleration of '
     "/sensors must be named"),
    ("law", "string", "control law: " + ", ".join(LAWS)),
    ("gains", "JSON object", "law and force-tracking gains by name with units in the name, e.g. "
     '{"K_f_N_per_m": 2.5e7, "Ki_V_per_Ns": 527.0}; required unless law is none'),
    ("force_sensor", "string", "bolt force sensor the force tracking reads: strain or cell (if law is not none)"),
    ("amplitude_n", "float [N]", "excitation force amplitude (impulse: peak); impulse, step-sine, sweep"),
    ("freq_hz", "JSON list [Hz]", "step-sine: the excitation frequencies in order; sweep: [f_start, f_end]"),
    ("duration_s", "float [s]", "length of the test (optional)"),
    ("description", "string", "free text (optional)"),
)
RUN_KEYS = ("config", "law", "estimator", "seed", "versions", "command")
"""Keys the "frictionrt" record of a simulation log (one with a /plant topic) must have."""
ACCELEROMETER_POINTS = {"a_tip_meas": "tip", "a_frf_meas": "frf"}  # the plant points the loop's sensors read

PROBLEM_KINDS = ("missing", "wrong unit", "wrong type", "non-monotonic time", "duplicate time", "NaN",
                 "wrong rate", "invalid")


@dataclass(frozen=True)
class Problem:
    """What is wrong where: ``where`` a topic ("/sensors"), a field ("/sensors.a_tip_meas") or a
    metadata entry ("metadata test.kind"); ``kind`` one of PROBLEM_KINDS; ``detail`` the specifics."""
    where: str
    kind: str
    detail: str

    def __str__(self) -> str:
        return f"{self.where}: {self.kind}: {self.detail}"

    def to_dict(self) -> dict:
        return asdict(self)




def _md_table(header: tuple[str, ...], rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def signal_table() -> str:
    """The signal table of docs/data-format.md (markdown), from ``SIGNALS``."""
    return _md_table(("topic", "signal", "field", "type", "unit", "row k holds", "meaning", "required"),
                     ((f"/{e.owner}", f"`{e.name}`", f"`{lower_rule(e.name)}`", e.type, e.unit, e.at, e.meaning,
                       "yes" if e.name in REQUIRED else ("with a law" if e.name in SETPOINTS else ""))
                      for e in SIGNALS))


def required_table() -> str:
    """The required fields of docs/data-format.md (markdown), from ``REQUIRED`` and ``SETPOINTS``."""
    rows = []
    for name in REQUIRED + SETPOINTS:
        e = next(e for e in SIGNALS if e.name == name)
        rows.append((f"/{e.owner}", f"`{e.name}`", f"`{ros2_field(e.name)}`", e.type, e.unit,
                     "always" if name in REQUIRED else "when test.law is not none"))
    return _md_table(("topic", "signal", "field", "type", "unit", "required"), rows)


def keys_table() -> str:
    """The "test" record table of docs/data-format.md (markdown), from ``TEST_KEYS``."""
    return _md_table(("key", "value", "meaning"), ((f"`{k}`", t, m) for k, t, m in TEST_KEYS))


# --- the test record of a run -------------------------------------------------------------------

def law_gains(loop) -> dict[str, float]:
    """The gains of a loop's law and force tracking, names with units (``TEST_KEYS`` gains)."""
    t, d = loop.cfg.tracking, loop.design
    law = {"passive": {"F_passive_N": t.F_passive_N},
           "hysteresis": {"K_f_N_per_m": t.K_f, "T1_s": t.T1_s, "F_min_N": t.F_min_N, "F_max_N": t.F_max_N},
           "lyapunov": {"eps_m_s": t.eps_m_s, "F_min_N": t.F_min_N, "F_max_N": t.F_max_N}}[loop.law]
    return law | {"setpoint_filter_hz": t.setpoint_filter_hz, "Kp_V_per_N": d.Kp, "Ki_V_per_Ns": d.Ki,
                  "Kd_Vs_per_N": d.Kd, "Tf_s": d.Tf}


def run_test_record(loop, freq_hz: float, amp_n: float, duration_s: float) -> dict[str, str]:
    """The "test" record of a simulated sine dwell from rest (``frictionrt simulate``): a
    step-sine of one frequency, excitation point, sensor positions, law and gains."""
    cfg = loop.cfg
    x = {p.name: p.x_m for p in cfg.plant.points}
    screw = require_adaptive_screw(cfg, "a run's test record")
    pos = {s: x[p] for s, p in ACCELEROMETER_POINTS.items()} | {"F_strain": screw.x_m, "F_cell": screw.x_m}
    return {"kind": "step-sine", "excitation_x_m": repr(float(x[cfg.plant.excitation_point])),
            "sensor_positions_m": json.dumps(pos), "law": loop.law, "gains": json.dumps(law_gains(loop)),
            "force_sensor": loop.force_sensor, "amplitude_n": repr(float(amp_n)),
            "freq_hz": json.dumps([float(freq_hz)]), "duration_s": repr(float(duration_s)),
            "description": f"simulated sine dwell from rest, {loop.estimator} estimator"}


# --- validation ------------------------------------------------------------------------------------

@dataclass
class _Topic:
    schema: object = None
    channel: object = None
    times: list | None = None
    seqs: list | None = None
    data: list | None = None


def _read(path: Path) -> tuple[dict, dict[str, _Topic]]:
    """Metadata records and, per topic, schema, channel, log times, sequences and payloads in file
    order. ValueError for an unreadable file."""
    if not path.is_file():
        raise ValueError(f"{path}: {'not a file' if path.exists() else 'no such file'}")
    check_framing(path)
    topics: dict[str, _Topic] = {}
    try:
        with open(path, "rb") as f:
            reader = make_reader(f, validate_crcs=True)
            meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
            summary = reader.get_summary()
            fast = summary is not None and summary.chunk_indexes and \
                all(ci.compression in ("zstd", "") for ci in summary.chunk_indexes)
            for (schema, channel), (payloads, times, seqs) in (chunk_messages(f, summary) if fast
                                                              else iter_messages(reader)):
                tp = topics.get(channel.topic)
                if tp is None:
                    tp = topics[channel.topic] = _Topic(schema, channel, [], [], [])
                tp.times.append(times)
                tp.seqs.append(seqs)
                tp.data.append(payloads)
    except (McapError, zstandard.ZstdError, OSError, EOFError, struct.error, ValueError, KeyError, TypeError) as e:
        # KeyError, TypeError: mcap's reader on a corrupt summary (e.g. a message of an unlisted channel)
        raise ValueError(f"{path}: unreadable MCAP file ({type(e).__name__}: {e})") from None
    for tp in topics.values():   # one array of times and sequences; payloads in parts (rt.log.mcap_log.payload_rows)
        tp.times, tp.seqs = np.concatenate(tp.times), np.concatenate(tp.seqs)
    return meta, topics


def _layout(meta: dict, topics: dict[str, _Topic], problems: list[Problem]):
    """(version, signals, rate [Hz], start [ns] or None, {topic: Topic}) of the file: its "signals"
    record, or the defaults of a file without one (rt.log.mcap_log.file_topics); None with a problem
    appended if neither gives a layout."""
    schemas = {n: tp.schema for n, tp in topics.items() if tp.schema is not None and tp.schema.encoding == "ros2msg"}
    try:
        return file_topics(meta, schemas)
    except (ValueError, KeyError, TypeError, json.JSONDecodeError) as e:
        msg = f"{type(e).__name__}: {e}" if isinstance(e, (KeyError, TypeError, json.JSONDecodeError)) else str(e)
        if "signals" not in meta:
            problems.append(Problem("metadata signals", "missing", f"no 'signals' record and the schemas give no "
                                    f"layout: {msg}"))
        elif "rate_hz" in msg:
            problems.append(Problem("metadata signals.rate_hz", "wrong rate", f"{msg}: must be a positive whole "
                                    "number of Hz"))
        else:
            problems.append(Problem("metadata signals.signals", "invalid", f"{msg} (a JSON list of {{name, field, "
                                    "type, unit, owner, column}})"))
        return None


def _float(rec: dict, key: str, problems: list[Problem], required: bool = True) -> float | None:
    if key not in rec:
        if required:
            problems.append(Problem(f"metadata test.{key}", "missing", "required"))
        return None
    try:
        v = float(rec[key])
    except ValueError:
        v = float("nan")
    if not math.isfinite(v):
        problems.append(Problem(f"metadata test.{key}", "wrong type", f"{rec[key]!r} is not a finite number"))
        return None
    return v


def _json(rec: dict, key: str, typ: type, problems: list[Problem]):
    if key not in rec:
        problems.append(Problem(f"metadata test.{key}", "missing", "required"))
        return None
    try:
        v = json.loads(rec[key])
    except json.JSONDecodeError:
        v = None
    numbers = v.values() if isinstance(v, dict) else v if isinstance(v, list) else ()
    if not isinstance(v, typ) or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                         and math.isfinite(x) for x in numbers):
        problems.append(Problem(f"metadata test.{key}", "wrong type",
                                f"{rec[key]!r} is not a JSON {typ.__name__} of finite numbers"))
        return None
    return v


def _check_test(meta: dict, signals: tuple, rate: int | None, problems: list[Problem]) -> str:
    """Check the "test" record; returns its law ("none" if absent or unknown)."""
    rec = meta.get("test")
    if rec is None:
        problems.append(Problem("metadata test", "missing", "no 'test' record: what was done (kind, excitation "
                                "point, sensor positions, law) has no default; add it with the MCAP writer's "
                                "add_metadata(\"test\", {\"kind\": ..., ...}), keys in docs/data-format.md"))
        return "none"
    kind = rec.get("kind")
    if kind is None:
        problems.append(Problem("metadata test.kind", "missing", "required"))
    elif kind not in KINDS:
        problems.append(Problem("metadata test.kind", "invalid", f"{kind!r}: one of {list(KINDS)}"))
    _float(rec, "excitation_x_m", problems)
    pos = _json(rec, "sensor_positions_m", dict, problems)
    if pos is not None:
        names = {n for n, _, _ in signals}
        for n in sorted(set(pos) - names):
            problems.append(Problem("metadata test.sensor_positions_m", "invalid", f"{n!r} is not a signal of the file"))
        for n, u, o in signals:
            if o == "sensors" and u == "m/s^2" and n not in pos:
                problems.append(Problem("metadata test.sensor_positions_m", "missing", f"no position for {n}"))
    law = rec.get("law")
    if law is None:
        problems.append(Problem("metadata test.law", "missing", "required (none for no controller)"))
        law = "none"
    elif law not in LAWS:
        problems.append(Problem("metadata test.law", "invalid", f"{law!r}: one of {list(LAWS)}"))
        law = "none"
    if law != "none":
        _json(rec, "gains", dict, problems)
        if rec.get("force_sensor") not in ("strain", "cell"):
            problems.append(Problem("metadata test.force_sensor", "missing" if "force_sensor" not in rec else "invalid",
                                    "strain or cell, required with a law"))
    if kind in ("impulse", "step-sine", "sweep"):
        a = _float(rec, "amplitude_n", problems)
        if a is not None and a < 0:
            problems.append(Problem("metadata test.amplitude_n", "invalid", f"{a:g} N: must be >= 0"))
    if kind in ("step-sine", "sweep"):
        f = _json(rec, "freq_hz", list, problems)
        if f is not None:
            nyq = rate / 2 if rate else math.inf
            if not f or (kind == "sweep" and len(f) != 2) or any(not 0 < x < nyq for x in f):
                problems.append(Problem("metadata test.freq_hz", "invalid", f"{f}: {'[f_start, f_end]' if kind == 'sweep' else 'a non-empty list'} "
                                        f"of frequencies in (0, {nyq:g}) Hz"))
    if "duration_s" in rec:
        _float(rec, "duration_s", problems, required=False)
    return law


def _check_run(meta: dict, rate: int | None, plant_present: bool, problems: list[Problem]) -> None:
    """The "frictionrt" record: required keys for a simulation log; a stored configuration must
    load and agree with the rate."""
    rec = meta.get("frictionrt")
    if rec is None:
        if plant_present:
            problems.append(Problem("metadata frictionrt", "missing", "a simulation log (it has /plant) must store "
                                    "its configuration, law, estimator, seed, versions and command"))
        return
    if plant_present:
        for key in RUN_KEYS:
            if key not in rec:
                problems.append(Problem(f"metadata frictionrt.{key}", "missing", "required in a simulation log"))
    if "config" in rec:
        from frictionrt.rt.common.config import ConfigError, loads   # not via rt.loop.replay: that imports the compiled loop (2 s)
        try:
            cfg = loads(rec["config"], (), source="the stored configuration", stored=True)
        except ConfigError as exc:
            problems.append(Problem("metadata frictionrt.config", "invalid", f"metadata frictionrt.config: {exc}"))
            return
        if rate is not None and cfg.rt.rate_hz != rate:
            problems.append(Problem("metadata signals.rate_hz", "wrong rate",
                                    f"{rate} Hz, but the stored configuration runs at rt.rate_hz = {cfg.rt.rate_hz:g} Hz"))


def _check_topic(path: Path, name: str, raw: _Topic, tp: Topic, version: int, rate: int, start: int | None,
                 problems: list[Problem]) -> np.ndarray | None:
    """Schema, message sizes, times and values of one topic; returns its ticks (file order) if
    they are known and their times lie on the tick grid, else None."""
    s, ch = raw.schema, raw.channel
    if s is None or s.encoding != "ros2msg" or ch.message_encoding != "cdr":
        problems.append(Problem(name, "wrong type", "schema encoding must be ros2msg and message encoding cdr, got "
                                f"{getattr(s, 'encoding', None)!r} / {ch.message_encoding!r}"))
        return None
    if s.name != tp.schema_name:
        problems.append(Problem(name, "wrong type", f"schema name {s.name!r}, must be {tp.schema_name!r}"))
    try:
        parsed = parse_schema(s.data)
    except ValueError as e:
        problems.append(Problem(name, "wrong type", str(e)))
        return None
    types = {f: t for t, f in parsed}
    ok = True
    for sig, fld in zip(tp.names, tp.fields):
        want = field_type(sig, tp.owner) if version >= 1 else "float64"
        if fld not in types:
            problems.append(Problem(f"{name}.{sig}", "missing", f"field {fld} is in the 'signals' record but not in "
                                    "the schema"))
            ok = False
        elif types[fld] != want:
            problems.append(Problem(f"{name}.{sig}", "wrong type", f"{types[fld]} {fld}, must be {want}"))
            ok = False
    if ok and parsed != tp.schema_fields:
        problems.append(Problem(name, "invalid", "schema fields differ from the 'signals' record (order, stamp and "
                                f"tick, or extra fields): {[f for _, f in parsed]}"))
        ok = False
    if not ok:
        return None
    try:
        rows = payload_rows(path, tp, raw.data)
    except ValueError as e:
        problems.append(Problem(name, "wrong type", str(e).removeprefix(f"{path}: ")))
        return None
    k, stamp, vals = tp.decode(rows)
    t = raw.times.astype(np.int64) if raw.times.max(initial=0) < 2**63 else None
    n = len(rows)
    if t is None or (k is not None and (k.min(initial=0) < 0 or k.max(initial=0) > MAX_TICK)):
        problems.append(Problem(name, "invalid", f"ticks or log times beyond the last representable tick "
                                f"(k = {MAX_TICK} at {rate} Hz)"))
        return None
    if k is None:      # version 0: the tick is in the log time, checked against the sequence
        k = ticks_of_times(raw.times, rate)
        if k is None:
            problems.append(Problem(name, "invalid", f"log times beyond the last representable tick (k = {MAX_TICK} "
                                    f"at {rate} Hz, {int(tick_time_ns(MAX_TICK, rate))} ns)"))
            return None
        off = tick_time_ns(k, rate) != t
        seq_bad = (k & 0xFFFFFFFF) != raw.seqs.astype(np.int64)
        if seq_bad.any() and not off.any():
            problems.append(Problem(name, "invalid", f"{int(seq_bad.sum())} sequence numbers are not k mod 2^32 "
                                    f"(first at tick {int(k[seq_bad][0])})"))
        rule = "log_time must be (k 10^9) // rate_hz (log format 0)"
    else:
        t0 = start if start is not None else (int(t[0]) - int(tick_time_ns(k[0], rate)) if n else 0)
        off = t0 + tick_time_ns(k, rate) != t
        if (stamp != t).any():
            bad = stamp != t
            problems.append(Problem(name, "invalid", f"{int(bad.sum())} stamps differ from the log time (first at "
                                    f"tick {int(k[bad][0])})"))
        rule = "log_time must be start_ns + (tick 10^9) // rate_hz"
    if off.any():
        problems.append(Problem(name, "wrong rate", f"{int(off.sum())} of {n} log times are off the {rate} Hz tick "
                                f"grid (first {int(t[off][0])} ns); {rule}"))
        return None
    dk = np.diff(k)
    if (dk < 0).any():
        problems.append(Problem(name, "non-monotonic time", f"{int((dk < 0).sum())} messages go back in time "
                                f"(first: tick {int(k[1:][dk < 0][0])} after tick {int(k[:-1][dk < 0][0])})"))
    if (dk == 0).any():
        problems.append(Problem(name, "duplicate time", f"{int((dk == 0).sum())} messages repeat a tick "
                                f"(first: tick {int(k[1:][dk == 0][0])})"))
    if len(dk) and (dk > 0).any() and np.median(dk[dk > 0]) > 1:
        step = int(np.median(dk[dk > 0]))
        problems.append(Problem(name, "wrong rate", f"messages come every {step} ticks: the data is at "
                                f"{rate / step:g} Hz, the 'signals' record says {rate} Hz"))
    for j, sig in enumerate(tp.names):
        bad = ~np.isfinite(vals[:, j])
        if bad.any():
            problems.append(Problem(f"{name}.{sig}", "NaN", f"{int(bad.sum())} of {n} samples are NaN or inf "
                                    f"(first at tick {int(k[bad][0])})"))
    return k


def validate(path) -> list[Problem]:
    """Check the file at ``path`` against the measurement format (module docstring); the list of
    problems, empty if the file is valid. ValueError naming the file if it cannot be read."""
    path = Path(path)
    meta, topics = _read(path)
    problems: list[Problem] = []
    layout = _layout(meta, topics, problems)
    version, signals, rate, start, tps = layout if layout is not None else (0, (), None, None, {})
    law = _check_test(meta, signals, rate, problems)
    _check_run(meta, rate, "/plant" in topics, problems)
    by_name = {n: (u, o) for n, u, o in signals}
    for n, u, o in signals:
        e = entry_of(o, n)
        if e is not None and e.unit != u:
            problems.append(Problem(f"/{o}.{n}", "wrong unit", f"{u!r}, must be {e.unit!r}"))
    required = REQUIRED + (SETPOINTS if law != "none" else ())
    for n in required:
        want = next(e for e in SIGNALS if e.name == n)
        if n not in by_name:
            problems.append(Problem(f"/{want.owner}.{n}", "missing", f"required ({want.meaning}; field "
                                    f"{ros2_field(n)})"))
        elif by_name[n][1] != want.owner:
            problems.append(Problem(f"/{want.owner}.{n}", "missing", f"recorded under /{by_name[n][1]} instead"))
    ticks = {}
    for name, tp in tps.items():
        if name not in topics:
            if any(by_name[n][1] == tp.owner for n in required if n in by_name):
                problems.append(Problem(name, "missing", "topic has no messages, but holds required fields "
                                        f"({', '.join(n for n in required if by_name.get(n, ('', ''))[1] == tp.owner)})"))
            continue
        k = _check_topic(path, name, topics[name], tp, version, rate, start, problems)
        if k is not None:
            ticks[name] = k
    if len(ticks) > 1:
        union = np.unique(np.concatenate(list(ticks.values())))
        for name, k in ticks.items():
            lack = len(union) - len(np.unique(k))
            if lack:
                problems.append(Problem(name, "missing", f"{lack} ticks that other topics have"))
    return problems


def main() -> None:
    """Print the generated tables of docs/data-format.md."""
    print(signal_table())
    print(required_table())
    print(keys_table())


if __name__ == "__main__":
    main()
