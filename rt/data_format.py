"""The measurement format (docs/data-format.md): what a run log or a measurement must carry, and
a validator that names what is missing or wrong.

A file is an MCAP log in the layout of ``rt.mcap_log`` (topics per owning package, ros2msg
schemas of float64 fields, CDR messages, one message per tick at log_time = (k 10^9) // rate_hz
ns) with the metadata records "signals" (the layout), "test" (what was done: ``TEST_KEYS``)
and, for the project's own runs, "frictionrt" (configuration, law, estimator, seed, versions,
command line).

``SIGNALS`` is the registry of every signal the format knows: name (``<point>`` stands for a
point name of plant.points, ``<screw>`` for a screw name of plant.screws, ``<j>`` for a contact
pair index 0, 1, ...), unit, owner (topic
/owner), the instant row k holds, and its meaning. tests/test_data_format.py checks it against
the loop's own signal list (``rt.loop.loop_signals``) in both directions and checks that the
tables of docs/data-format.md are ``signal_table()`` and ``required_table()`` verbatim
(``python -m rt.data_format`` prints them).

``validate(path)`` returns the list of ``Problem`` s (empty: valid) and raises ValueError only
for a file that cannot be read at all (not MCAP, truncated, corrupt).
"""
from __future__ import annotations

import json
import math
import re
import struct
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import zstandard
from mcap.exceptions import McapError
from mcap.reader import make_reader

from rt.mcap_log import (CDR_LE, MAX_TICK, OWNERS, _check_framing, _chunk_messages, _iter_messages, field_names,
                         schema_name, tick_time_ns)


class Entry(NamedTuple):
    """One signal of the format."""
    name: str      # field name; <point> = a plant point name, <j> = a contact pair index
    unit: str
    owner: str     # topic /owner
    at: str        # the instant (or interval) row k holds
    meaning: str


SIGNALS = (
    Entry("F_exc", "N", "rt", "[t_k, t_k+1)", "excitation force at test.excitation_x_m, +z (up), held over the tick"),
    Entry("tick_ns", "ns", "rt", "tick k", "execution time of the loop's tick (simulation only)"),
    Entry("late_ns", "ns", "rt", "tick k", "lateness of the tick's start against its deadline (paced runs; 0 offline)"),
    Entry("fault_code", "-", "rt", "tick k", "supervisor: code of the first failing check of the tick, 0 none "
          "(docs/reliability.md)"),
    Entry("fault_latched", "-", "rt", "tick k", "supervisor: code of the latched fault, 0 while active"),
    Entry("passive", "-", "rt", "tick k", "supervisor: 1 while it commands passive F_min instead of the law's F_set"),
    Entry("a_tip_meas", "m/s^2", "sensors", "t_k", "accelerometer at test.sensor_positions_m.a_tip_meas (tip), "
          "after anti-alias filter, noise and ADC"),
    Entry("a_frf_meas", "m/s^2", "sensors", "t_k", "accelerometer at test.sensor_positions_m.a_frf_meas (FRF point), "
          "after anti-alias filter, noise and ADC"),
    Entry("v_tip_meas", "m/s", "sensors", "t_k", "tip velocity: the controller's leaky integral of a_tip_meas "
          "(corner sensors.velocity_corner_hz)"),
    Entry("F_strain", "N", "sensors", "t_k", "adaptive screw bolt force, strain gauge, after noise and ADC"),
    Entry("F_cell", "N", "sensors", "t_k", "adaptive screw bolt force, piezo force cell, after noise and ADC"),
    Entry("u_rel_hat", "m", "observer", "t_k", "estimated tangential relative displacement at the adaptive screw"),
    Entry("v_rel_hat", "m/s", "observer", "t_k", "estimated relative velocity at the adaptive screw"),
    Entry("innovation", "m/s", "observer", "t_k", "observer innovation (measured minus predicted tip velocity); "
          "0 with the oracle"),
    Entry("f_r_hat", "N", "observer", "t_k", "observer's friction force estimate; 0 with the oracle"),
    Entry("F_set", "N", "tracking", "t_k", "the control law's bolt force setpoint F*"),
    Entry("u0", "m", "tracking", "t_k+1", "RT1 amplitude of u_rel (hysteresis law; tracking.rt1)"),
    Entry("F_set_filtered", "N", "tracking", "t_k", "F* after the setpoint prefilter: the force tracking's setpoint"),
    Entry("V_cmd", "V", "tracking", "[t_k, t_k+1)", "voltage command to the DAC (amplifier input), held over the tick"),
    Entry("saturated", "-", "tracking", "t_k", "+1 command at V_max, -1 at V_min, 0 inside"),
    Entry("F_stack", "N", "actuator", "t_k+1", "the stack's force at zero separation of the beams (simulation only)"),
    Entry("V_dac", "V", "actuator", "[t_k, t_k+1)", "DAC output (16 bit, held)"),
    Entry("v_f", "V", "actuator", "t_k+1", "output of the 30 kHz analog low-pass"),
    Entry("V_a", "V", "actuator", "t_k+1", "piezo stack voltage (amplifier output)"),
    Entry("i", "A", "actuator", "last substep", "piezo stack current, C dV_a/dt, mean over the last actuator "
          "substep before t_k+1"),
    Entry("P", "W", "actuator", "last substep", "amplifier output power V_a i, mean over the last substep"),
    Entry("E", "J", "actuator", "t_k+1", "energy delivered by the amplifier since the start, integral of abs(V_a i) dt"),
    Entry("F_strain_a", "N", "actuator", "t_k+1", "strain gauge analog output (before noise and ADC)"),
    Entry("F_cell_a", "N", "actuator", "t_k+1", "force cell analog output (before noise and ADC)"),
    Entry("w_<point>", "m", "plant", "t_k+1", "transverse displacement w at the point"),
    Entry("v_<point>", "m/s", "plant", "t_k+1", "transverse velocity w' at the point"),
    Entry("a_<point>", "m/s^2", "plant", "t_k+1", "transverse acceleration w'' at the point"),
    Entry("u_rel", "m", "plant", "t_k+1", "tangential relative displacement at the adaptive screw"),
    Entry("v_rel", "m/s", "plant", "t_k+1", "tangential relative velocity at the adaptive screw"),
    Entry("g_n_<j>", "m", "plant", "t_k+1", "normal gap of contact pair j (j = 0 at interface.x_start_m)"),
    Entry("g_t_<j>", "m", "plant", "t_k+1", "tangential relative displacement of contact pair j"),
    Entry("f_n_<j>", "N", "plant", "t_k+1", "normal contact force of pair j"),
    Entry("f_t_<j>", "N", "plant", "t_k+1", "tangential (Jenkins) force of pair j"),
    Entry("E_fric", "J", "plant", "t_k+1", "energy dissipated by friction since the start"),
    Entry("E_damp", "J", "plant", "t_k+1", "energy dissipated by structural and interface damping"),
    Entry("W_exc", "J", "plant", "t_k+1", "work of the excitation force"),
    Entry("W_screw", "J", "plant", "t_k+1", "work of the adaptive screw force"),
    Entry("newton_iter", "-", "plant", "tick k", "contact Newton iterations of the tick (-1: a failed solve)"),
    Entry("substep_fallbacks", "-", "plant", "tick k", "substeps redone on finer substeps in the tick"),
    Entry("abar_<point>", "m/s^2", "plant", "[t_k, t_k+1]", "mean acceleration over the tick, what the "
          "accelerometers sample"),
    Entry("g_bolt_<screw>", "m", "plant", "t_k+1", "the beams' separation at the screw (> 0 opening)"),
    Entry("F_N1", "N", "plant", "t_k+1", "adaptive screw (bolt) force: F_stack (held) + k (g - g_ref) "
          "(true, simulation only)"),
    Entry("F_bolt_<screw>", "N", "plant", "t_k+1", "force of an ordinary bolt, F_N + k (g - g_ref)"),
    Entry("dF_N1", "N", "plant", "t_k+1", "the adaptive bolt's response to the separation, k (g - g_ref)"),
)

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


def _pattern(name: str) -> re.Pattern:
    rx = re.escape(name)
    for token, part in (("<point>", r"[A-Za-z0-9_]+"), ("<screw>", r"[A-Za-z0-9_]+"), ("<j>", r"[0-9]+")):
        rx = rx.replace(re.escape(token), part)
    return re.compile(rx + r"\Z")


_EXACT = {(e.owner, e.name): e for e in SIGNALS if "<" not in e.name}
_PATTERNS = [(e, _pattern(e.name)) for e in SIGNALS if "<" in e.name]


def entry_of(owner: str, name: str) -> Entry | None:
    """The registry entry of a signal: an exact name first (u_rel is not v_<point>), then a pattern."""
    e = _EXACT.get((owner, name))
    if e is not None:
        return e
    return next((e for e, rx in _PATTERNS if e.owner == owner and rx.match(name)), None)


def _md_table(header: tuple[str, ...], rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def signal_table() -> str:
    """The signal table of docs/data-format.md (markdown), from ``SIGNALS``."""
    return _md_table(("topic", "field", "unit", "row k holds", "meaning", "required"),
                     ((f"/{e.owner}", f"`{e.name}`", e.unit, e.at, e.meaning,
                       "yes" if e.name in REQUIRED else ("with a law" if e.name in SETPOINTS else ""))
                      for e in SIGNALS))


def required_table() -> str:
    """The required fields of docs/data-format.md (markdown), from ``REQUIRED`` and ``SETPOINTS``."""
    rows = []
    for name in REQUIRED + SETPOINTS:
        e = next(e for e in SIGNALS if e.name == name)
        rows.append((f"/{e.owner}", f"`{e.name}`", e.unit, "always" if name in REQUIRED else "when test.law is not none"))
    return _md_table(("topic", "field", "unit", "required"), rows)


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
    screw = next(s for s in cfg.plant.screws if s.adaptive)
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
    _check_framing(path)
    topics: dict[str, _Topic] = {}
    try:
        with open(path, "rb") as f:
            reader = make_reader(f, validate_crcs=True)
            meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
            summary = reader.get_summary()
            fast = summary is not None and summary.chunk_indexes and \
                all(ci.compression in ("zstd", "") for ci in summary.chunk_indexes)
            for (schema, channel), (payloads, times, seqs) in (_chunk_messages(f, summary) if fast
                                                              else _iter_messages(reader)):
                tp = topics.get(channel.topic)
                if tp is None:
                    tp = topics[channel.topic] = _Topic(schema, channel, [], [], [])
                tp.times.append(times)
                tp.seqs.append(seqs)
                tp.data.extend(payloads if isinstance(payloads, list) else [payloads])
    except (McapError, zstandard.ZstdError, OSError, EOFError, struct.error, ValueError, KeyError, TypeError) as e:
        # KeyError, TypeError: mcap's reader on a corrupt summary (e.g. a message of an unlisted channel)
        raise ValueError(f"{path}: unreadable MCAP file ({type(e).__name__}: {e})") from None
    for tp in topics.values():   # one array of times and sequences; payloads as bytes or rows
        tp.times, tp.seqs = np.concatenate(tp.times), np.concatenate(tp.seqs)
        tp.data = _payload_rows(tp.data)
    return meta, topics


def _payload_rows(parts: list) -> np.ndarray | list[bytes]:
    """A topic's payloads from its parts (arrays of equally long rows, or single payloads): one
    (n, size) uint8 array if all rows have one size, else a list of bytes."""
    if all(isinstance(p, np.ndarray) for p in parts) and len({p.shape[1] for p in parts}) == 1:
        return np.concatenate(parts)
    out: list[bytes] = []
    for p in parts:
        if isinstance(p, np.ndarray):
            out.extend(row.tobytes() for row in p)
        else:
            out.append(bytes(p))
    return out


def _signals_of(meta: dict, problems: list[Problem]) -> tuple[tuple, int | None]:
    """The layout and rate of the "signals" record (problems appended)."""
    rec = meta.get("signals")
    if rec is None:
        problems.append(Problem("metadata signals", "missing", "no 'signals' record: the layout (names, units, "
                                "topics) and rate are unknown"))
        return (), None
    try:
        rows = json.loads(rec["signals"])
        signals = tuple((str(r["name"]), str(r["unit"]), str(r["owner"])) for r in rows)
        fields = [r["field"] for r in rows]
    except (KeyError, TypeError, json.JSONDecodeError) as e:
        problems.append(Problem("metadata signals.signals", "invalid", f"not the JSON list of {{name, field, unit, "
                                f"owner, column}} ({type(e).__name__}: {e})"))
        return (), None
    if fields != list(field_names(signals)) or [r.get("column") for r in rows] != list(range(len(rows))):
        problems.append(Problem("metadata signals.signals", "invalid", "fields or columns do not follow the "
                                "naming rule of rt.mcap_log"))
    for name, _, owner in signals:
        if owner not in OWNERS:
            problems.append(Problem(f"metadata signals {name}", "invalid", f"owner {owner!r} is not one of {list(OWNERS)}"))
    rate = None
    try:
        r = float(rec["rate_hz"])
        if math.isfinite(r) and r > 0 and r.is_integer():
            rate = int(r)
    except (KeyError, ValueError):
        pass
    if rate is None:
        problems.append(Problem("metadata signals.rate_hz", "wrong rate",
                                f"{rec.get('rate_hz')!r}: must be a positive whole number of Hz"))
    return signals, rate


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
        problems.append(Problem("metadata test", "missing", "no 'test' record (kind, excitation point, sensor "
                                "positions, law): docs/data-format.md"))
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
        from rt.config import ConfigError, loads   # not via rt.replay: that imports the compiled loop (2 s)
        try:
            cfg = loads(rec["config"], (), source="the stored configuration")
        except ConfigError as exc:
            problems.append(Problem("metadata frictionrt.config", "invalid", f"metadata frictionrt.config: {exc}"))
            return
        if rate is not None and cfg.rt.rate_hz != rate:
            problems.append(Problem("metadata signals.rate_hz", "wrong rate",
                                    f"{rate} Hz, but the stored configuration runs at rt.rate_hz = {cfg.rt.rate_hz:g} Hz"))


def _parse_schema(text: bytes) -> list[tuple[str, str]] | None:
    """(type, field) per line of a ros2msg schema, None if it is not of that form."""
    try:
        lines = [ln.split("#")[0].strip() for ln in text.decode().splitlines()]
    except UnicodeDecodeError:
        return None
    out = []
    for ln in filter(None, lines):
        parts = ln.split()
        if len(parts) != 2:
            return None
        out.append((parts[0], parts[1]))
    return out


def _check_topic(name: str, tp: _Topic, fields: list[tuple[str, str]], rate: int | None,
                 problems: list[Problem]) -> np.ndarray | None:
    """Schema, message sizes, times and values of one topic; returns its ticks (file order) if
    their times lie on the tick grid, else None. fields: (signal name, field) of the topic."""
    s, ch = tp.schema, tp.channel
    if s is None or s.encoding != "ros2msg" or ch.message_encoding != "cdr":
        problems.append(Problem(name, "wrong type", "schema encoding must be ros2msg and message encoding cdr, got "
                                f"{getattr(s, 'encoding', None)!r} / {ch.message_encoding!r}"))
        return None
    if s.name != schema_name(name[1:]):
        problems.append(Problem(name, "wrong type", f"schema name {s.name!r}, must be {schema_name(name[1:])!r}"))
    parsed = _parse_schema(s.data)
    if parsed is None:
        problems.append(Problem(name, "wrong type", "the schema is not one 'TYPE FIELD' per line"))
        return None
    types = dict((f, t) for t, f in parsed)
    ok = True
    for sig, fld in fields:
        if fld not in types:
            problems.append(Problem(f"{name}.{sig}", "missing", f"field {fld} is in the 'signals' record but not in "
                                    "the schema"))
            ok = False
        elif types[fld] != "float64":
            problems.append(Problem(f"{name}.{sig}", "wrong type", f"{types[fld]}, must be float64"))
            ok = False
    if [f for _, f in parsed] != [f for _, f in fields] and ok:
        problems.append(Problem(name, "invalid", "schema fields differ from the 'signals' record (order or extra "
                                f"fields): {[f for _, f in parsed]}"))
        ok = False
    if not ok or rate is None:
        return None
    size = len(CDR_LE) + 8 * len(fields)
    n = len(tp.data)
    if isinstance(tp.data, np.ndarray):
        rows = tp.data if tp.data.shape[1] == size else None
    else:
        buf = b"".join(tp.data)
        ok_sizes = len(buf) == n * size and all(len(d) == size for d in tp.data)
        rows = np.frombuffer(buf, np.uint8).reshape(n, size) if ok_sizes else None
    if rows is None:
        problems.append(Problem(name, "wrong type", f"messages must be {size} bytes (CDR header + {len(fields)} "
                                "float64)"))
        return None
    if np.any(rows[:, :4] != np.frombuffer(CDR_LE, np.uint8)):
        problems.append(Problem(name, "wrong type", "messages are not little-endian CDR (header 00 01 00 00)"))
        return None
    if max(tp.times) > tick_time_ns(MAX_TICK, rate):   # t rate would overflow int64
        problems.append(Problem(name, "invalid", f"log times beyond the last representable tick (k = {MAX_TICK} at "
                                f"{rate} Hz, {int(tick_time_ns(MAX_TICK, rate))} ns)"))
        return None
    t = np.array(tp.times, dtype=np.int64)
    k = -((-t * rate) // 10**9)
    off = tick_time_ns(k, rate) != t
    if off.any():
        problems.append(Problem(name, "wrong rate", f"{int(off.sum())} of {n} log times are off the {rate} Hz tick "
                                f"grid (first {int(t[off][0])} ns); log_time must be (k 10^9) // rate_hz"))
        return None
    seq_bad = (k & 0xFFFFFFFF) != np.array(tp.seqs, dtype=np.int64)
    if seq_bad.any():
        problems.append(Problem(name, "invalid", f"{int(seq_bad.sum())} sequence numbers are not k mod 2^32 "
                                f"(first at tick {int(k[seq_bad][0])})"))
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
    vals = np.ascontiguousarray(rows[:, 4:]).view("<f8")
    for j, (sig, _) in enumerate(fields):
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
    signals, rate = _signals_of(meta, problems)
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
            problems.append(Problem(f"/{want.owner}.{n}", "missing", f"required ({want.meaning})"))
        elif by_name[n][1] != want.owner:
            problems.append(Problem(f"/{want.owner}.{n}", "missing", f"recorded under /{by_name[n][1]} instead"))
    fields = field_names(signals)
    ticks = {}
    for owner in OWNERS:
        name = "/" + owner
        own = [(n, f) for (n, _, o), f in zip(signals, fields) if o == owner]
        if not own:
            continue
        if name not in topics:
            if any(by_name[n][1] == owner for n in required if n in by_name):
                problems.append(Problem(name, "missing", "topic has no messages, but holds required fields "
                                        f"({', '.join(n for n in required if by_name.get(n, ('', ''))[1] == owner)})"))
            continue
        k = _check_topic(name, topics[name], own, rate, problems)
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
