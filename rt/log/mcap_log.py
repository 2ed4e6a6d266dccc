"""Run logs as MCAP files of the ROS 2 profile: one CDR topic per owning package, encoded with
numpy in blocks. Log format version ``FORMAT_VERSION`` (docs/data-format.md).

A run's log is a float64 array (ticks, n_sig) whose columns are ``signals`` = (name, unit, owner)
(``frictionrt.rt.loop.build.loop_signals``), named by the paper's symbols. The file holds:

    header     profile "ros2", library "frictionrt"
    topics     /rt /sensors /observer /tracking /actuator /plant (those owning a column), in that
               order; one message per tick per topic, messages interleaved tick by tick
    schema     per topic, encoding "ros2msg", name "frictionrt/msg/<Owner>" (e.g.
               frictionrt/msg/Plant): "builtin_interfaces/Time stamp", "int64 tick", then one
               "TYPE FIELD" per signal of the owner in column order, FIELD = the signal's ROS 2
               name (``frictionrt.rt.log.registry.ros2_field``: F_N1 -> f_n1), TYPE its registry type (float64,
               or int64/int32/int8/bool for counts, codes and flags), then the definition of
               builtin_interfaces/Time (int32 sec, uint32 nanosec) as rosbag2 writes it
    message    encoding "cdr", little endian: the encapsulation header 00 01 00 00, then the
               fields aligned as CDR aligns them (to their size, relative to the end of the
               header; ``cdr_dtype``). float64 values are bit-exact copies of the log (NaN
               payloads, -0.0, inf and denormals included); an integer or bool field must hold
               a whole number of its range (ValueError otherwise), read back as that float64
    times      tick = k; stamp = log_time = publish_time = start_ns + (k * 10**9) // rate_hz [ns],
               the floor of t_k = k / rate_hz in exact integer arithmetic (k round(1e9 dt) would
               drift: 1/21000 s is not a whole number of ns), start_ns the run's UTC start
               (``start_time_ns``); sequence = k mod 2**32 (MCAP's field is uint32). The reader
               takes k from the tick field. rate_hz must be a whole number of Hz; ticks up to
               2**63 / 10**9 (5 days at 21 kHz)
    chunks     zstd, CHUNK_BYTES = 1 MiB uncompressed (17 per simulated second at 21 kHz; 4 or 16 MiB
               compress no better: the float64 noise dominates)
    metadata   record "frictionrt": the caller's strings (resolved configuration TOML, package
               versions, seed, start time, command line); record "signals": "format_version",
               "signals" = JSON list of {name, field, type, unit, owner, column}, "rate_hz",
               "dt_s", "start_ns", "time" (the rule above)
    key frames (version 2, optional) topic /keyframe with record "keyframes": the loop's state at
               fixed tick multiples (``frictionrt.rt.log.keyframes``), read into ``McapLog.keyframes``

Reading (``read_mcap``) is driven by each topic's schema, so it also reads:

- logs of version 0 (no "format_version"; the format before ROS 2 names): float64 fields named
  by the signals, no stamp or tick field, log_time = (k * 10**9) // rate_hz and sequence
  k mod 2**32 give the tick;
- files other tools wrote (e.g. ``mcap_ros2``'s writer) without the "signals" record: the
  signals are then the fields of the known topics in schema order, named back with
  ``frictionrt.rt.log.registry.signal_name``, their units the registry's ("" for a field it does not know),
  the rate ``DEFAULT_RATE_HZ``; any integer, float or bool field type is read.

Nothing is half-written: the writer writes ``NAME.mcap.part`` and renames it onto ``NAME.mcap``
on close. An exception inside ``with McapLogWriter(...)`` (a crash of the run, Ctrl-C) still
closes the file, so everything written up to then is a valid, readable MCAP file, and then
propagates. Only a killed process leaves a ``.part`` file behind (``frictionrt recover``,
rt/log/recover.py, salvages its complete chunks).

``read_mcap`` walks each chunk's records by their length prefixes and gathers the message
headers and payloads with numpy (``chunk_messages``; files without chunk indexes go through the
mcap library's reader), then decodes each topic with one structured view over its payload rows.

Length: the MCAP format both ways (schemas, layout and encoding for the writers, framing
checks and the chunk reader for the readers) in one file, so that writing and reading cannot
drift apart; the writer thread is rt/log/writer.py.
"""
from __future__ import annotations

import datetime
import json
import math
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Self

import numpy as np
import zstandard
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from frictionrt.rt.log.keyframes import RECORD as KF_RECORD
from frictionrt.rt.log.keyframes import TOPIC as KF_TOPIC
from frictionrt.rt.log.keyframes import KeyFrames, KeyframeCodec
from frictionrt.rt.log.registry import RESERVED, entry_of, field_names, field_type, signal_name

FORMAT_VERSION = 2             # of the log format (metadata signals.format_version; none: version 0)
PROFILE = "ros2"               # the MCAP header's profile (MCAP's well-known ROS 2 profile)
OWNERS = ("rt", "sensors", "observer", "tracking", "actuator", "plant")
CDR_LE = b"\x00\x01\x00\x00"   # CDR encapsulation header: plain CDR, little endian
CHUNK_BYTES = 1 << 20          # uncompressed chunk size [B]
MAGIC = b"\x89MCAP0\r\n"
MAX_TICK = (2**63 - 1) // 10**9  # k * 10**9 must fit int64
DEFAULT_RATE_HZ = 21000        # [Hz] of a file without the "signals" record (SPEC rt.rate_hz)
TIME_TYPE = "builtin_interfaces/Time"
TIME_DEF = "int32 sec\nuint32 nanosec\n"
SEPARATOR = "=" * 80           # between a ros2msg definition and the ones it uses
CDR_TYPES = {"float64": "<f8", "float32": "<f4", "int64": "<i8", "int32": "<i4", "int16": "<i2", "int8": "i1",
             "uint64": "<u8", "uint32": "<u4", "uint16": "<u2", "uint8": "u1", "byte": "u1", "char": "u1",
             "bool": "?"}      # ros2msg primitive -> numpy (CDR aligns each to its size)
_TIME_DTYPE = np.dtype([("sec", "<i4"), ("nanosec", "<u4")])


def tick_time_ns(k: np.ndarray, rate_hz: int) -> np.ndarray:
    """t_k = (k * 10**9) // rate_hz [ns] (int64), exact for 0 <= k <= MAX_TICK."""
    return (np.asarray(k, dtype=np.int64) * 10**9) // rate_hz


def tick_runs(k: np.ndarray) -> list[tuple[int, int]]:
    """(first row, end row) of each run of consecutive ticks in the increasing ticks k (a log
    with dropped blocks has several)."""
    cuts = [0, *(np.flatnonzero(np.diff(k) != 1) + 1).tolist(), len(k)]
    return list(zip(cuts[:-1], cuts[1:])) if len(k) else []


def check_metadata(path: Path, metadata: dict) -> None:
    """Metadata keys and values must be strings (ValueError naming the file otherwise)."""
    bad = [k for k, v in metadata.items() if not (isinstance(k, str) and isinstance(v, str))]
    if bad:
        raise ValueError(f"{path}: metadata keys and values must be strings: {bad}")


def check_block(path: Path, k0: int, block: np.ndarray, n_sig: int, k_next: int) -> tuple[int, int]:
    """A writer's block: float64 (n, n_sig), ticks k0 .. k0 + n - 1 starting at >= k_next (a gap
    is allowed) and ending at <= MAX_TICK. Returns (k0, n); ValueError naming the file otherwise."""
    k0 = int(k0)
    if block.ndim != 2 or block.shape[1] != n_sig or block.dtype != np.float64:
        raise ValueError(f"{path}: block must be float64 (n, {n_sig}), got {block.dtype} {block.shape}")
    n = block.shape[0]
    if k0 < k_next or k0 + n - 1 > MAX_TICK:
        raise ValueError(f"{path}: block ticks {k0}..{k0 + n - 1} must start at >= {k_next} "
                         f"and end at <= {MAX_TICK}")
    return k0, n


def check_rate(path: Path, rate_hz: float) -> int:
    """The tick rate as a whole number of Hz (ValueError naming the file otherwise)."""
    if not (math.isfinite(rate_hz) and rate_hz > 0 and float(rate_hz).is_integer()):
        raise ValueError(f"{path}: rate_hz must be a positive whole number of Hz, got {rate_hz}")
    return int(rate_hz)


def schema_name(owner: str) -> str:
    """The ros2msg schema name of an owner's topic, e.g. frictionrt/msg/Plant."""
    return f"frictionrt/msg/{owner.capitalize()}"


def utc_now() -> str:
    """Now as the "start_utc" metadata value: ISO 8601, milliseconds, zone +00:00."""
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="milliseconds")


def start_time_ns(metadata: dict[str, str]) -> int:
    """A run's UTC start [ns since 1970-01-01] from the metadata's "start_utc" (ISO 8601 with a
    zone, as ``frictionrt.rt.log.writer.run_metadata`` writes it); 0 if there is none. ValueError if unreadable."""
    text = metadata.get("start_utc")
    if text is None:
        return 0
    try:
        t = datetime.datetime.fromisoformat(text)
    except ValueError:
        raise ValueError(f"metadata start_utc {text!r} is not an ISO 8601 time") from None
    if t.tzinfo is None:
        raise ValueError(f"metadata start_utc {text!r} has no time zone (e.g. +00:00)")
    epoch = datetime.datetime(1970, 1, 1, tzinfo=datetime.UTC)
    return (t - epoch) // datetime.timedelta(microseconds=1) * 1000


def parse_schema(text: bytes) -> list[tuple[str, str]]:
    """(type, field) of the top-level fields of a ros2msg schema, constants left out; the only
    complex type is builtin_interfaces/Time (its definition, if given, must be int32 sec, uint32
    nanosec). ValueError naming the line for anything else (arrays, strings, other types)."""
    try:
        sections = text.decode().split("\n" + SEPARATOR + "\n")
    except UnicodeDecodeError:
        raise ValueError("the schema is not UTF-8 text") from None
    for sec in sections[1:]:
        head, _, body = sec.partition("\n")
        if head.strip() not in (f"MSG: {TIME_TYPE}", "MSG: builtin_interfaces/msg/Time") or \
                [ln.split() for ln in body.splitlines() if ln.split("#")[0].strip()] != [ln.split() for ln in
                                                                                         TIME_DEF.splitlines()]:
            raise ValueError(f"schema section {head.strip()!r}: only {TIME_TYPE} (int32 sec, uint32 nanosec) is "
                             "supported")
    out = []
    for ln in sections[0].splitlines():
        ln = ln.split("#")[0].strip()
        if not ln:
            continue
        parts = ln.split()
        if "=" in ln and not (len(parts) == 3 and "=" not in parts[1]):   # a constant: no payload
            continue
        if len(parts) not in (2, 3):
            raise ValueError(f"schema line {ln!r} is not 'TYPE FIELD [DEFAULT]'")
        typ = TIME_TYPE if parts[0] in ("builtin_interfaces/msg/Time", "time") else parts[0]
        if typ not in CDR_TYPES and typ != TIME_TYPE:
            raise ValueError(f"schema line {ln!r}: type {typ} is not supported (a numeric or bool primitive, or "
                             f"{TIME_TYPE})")
        out.append((typ, parts[1]))
    return out


def cdr_dtype(fields: list[tuple[str, str]]) -> np.dtype:
    """The numpy structured dtype of a CDR payload after its encapsulation header: the fields
    (type, name) in order, each aligned to its size (builtin_interfaces/Time: 4), no padding at
    the end. Padding bytes are part of no field (written as 0)."""
    names, formats, offsets, off = [], [], [], 0
    for typ, name in fields:
        dt = _TIME_DTYPE if typ == TIME_TYPE else np.dtype(CDR_TYPES[typ])
        align = 4 if typ == TIME_TYPE else dt.itemsize
        off = -(-off // align) * align
        names.append(name)
        formats.append(dt)
        offsets.append(off)
        off += dt.itemsize
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": off})


@dataclass(frozen=True)
class Topic:
    """One owner's topic: its log columns, their signals' ROS 2 fields and types, its schema.
    ``stamped``: the message starts with stamp and tick (version >= 1); version 0 has neither."""
    owner: str
    columns: np.ndarray   # int64 log columns, in order
    names: tuple[str, ...]    # the signals (paper's symbols)
    fields: tuple[str, ...]   # their ROS 2 fields
    types: tuple[str, ...]    # their ros2msg types
    stamped: bool = True

    @property
    def name(self) -> str:
        return "/" + self.owner

    @property
    def schema_name(self) -> str:
        return schema_name(self.owner)

    @property
    def schema_fields(self) -> list[tuple[str, str]]:
        """(type, field) of the message, stamp and tick included."""
        head = [(TIME_TYPE, "stamp"), ("int64", "tick")] if self.stamped else []
        return head + list(zip(self.types, self.fields))

    @property
    def schema_text(self) -> bytes:
        body = "".join(f"{t} {f}\n" for t, f in self.schema_fields)
        tail = f"{SEPARATOR}\nMSG: {TIME_TYPE}\n{TIME_DEF}" if self.stamped else ""
        return (body + tail).encode()

    @property
    def dtype(self) -> np.dtype:
        return cdr_dtype(self.schema_fields)

    @property
    def message_size(self) -> int:
        return len(CDR_LE) + self.dtype.itemsize

    def encode(self, k: np.ndarray, t_ns: np.ndarray, block: np.ndarray) -> np.ndarray:
        """(n, message_size) uint8 CDR messages of rows ``block`` (float64 (n, n_sig)) at ticks k
        and stamps t_ns [ns] (int64). ValueError if an integer or bool field gets a value that is
        not one of its type."""
        dt = self.dtype
        rec = np.zeros(len(k), dt)
        if self.stamped:
            rec["stamp"]["sec"], rec["stamp"]["nanosec"] = np.divmod(t_ns, 10**9)
            rec["tick"] = k
        for name, field, typ, c in zip(self.names, self.fields, self.types, self.columns):
            v = block[:, c]
            if typ != "float64":
                with np.errstate(invalid="ignore", over="ignore"):
                    x = v.astype(dt[field])
                bad = np.flatnonzero(x != v)
                if len(bad):
                    raise ValueError(f"signal {name} ({typ} {field}) is {float(v[bad[0]])!r} at tick {int(k[bad[0]])}: not "
                                     f"a value of {typ}")
                v = x
            rec[field] = v
        out = np.empty((len(k), self.message_size), np.uint8)
        out[:, :4] = np.frombuffer(CDR_LE, np.uint8)
        out[:, 4:] = rec.view(np.uint8).reshape(len(k), dt.itemsize)
        return out

    def decode(self, rows: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray]:
        """(ticks int64, stamps [ns] int64, values float64 (n, m)) of (n, message_size) uint8
        messages (CDR header checked by the caller); ticks and stamps None if not stamped."""
        rec = np.ascontiguousarray(rows[:, 4:]).view(self.dtype)[:, 0]
        vals = np.empty((len(rec), len(self.fields)))
        for j, f in enumerate(self.fields):
            vals[:, j] = rec[f]
        if not self.stamped:
            return None, None, vals
        stamp = rec["stamp"]["sec"].astype(np.int64) * 10**9 + rec["stamp"]["nanosec"]
        return rec["tick"].astype(np.int64), stamp, vals


def check_owners(path: Path, signals) -> None:
    """ValueError naming the file if a signal's owner is not one of OWNERS."""
    unknown = sorted({o for _, _, o in signals} - set(OWNERS))
    if unknown:
        raise ValueError(f"{path}: unknown signal owner(s) {unknown}; owners are {list(OWNERS)}")


def topics_of(signals, fields=None, types=None, stamped: bool = True) -> tuple[Topic, ...]:
    """The topics of a signal layout, in OWNERS order; fields and types per signal default to
    the registry's rule (``frictionrt.rt.log.registry``; ValueError for a signal without a valid field)."""
    fields = field_names(signals) if fields is None else tuple(fields)
    types = tuple(field_type(n, o) for n, _, o in signals) if types is None else tuple(types)
    owners = [o for _, _, o in signals]
    out = []
    for owner in OWNERS:
        cols = [c for c, o in enumerate(owners) if o == owner]
        if cols:
            out.append(Topic(owner, np.array(cols, dtype=np.int64), tuple(signals[c][0] for c in cols),
                             tuple(fields[c] for c in cols), tuple(types[c] for c in cols), stamped))
    return tuple(out)


def signals_record(signals, rate_hz: int, start_ns: int = 0) -> dict[str, str]:
    """The "signals" metadata record: the format version, the layout, the rate, the start, the time rule."""
    rows = [{"name": n, "field": f, "type": field_type(n, o), "unit": u, "owner": o, "column": c}
            for c, ((n, u, o), f) in enumerate(zip(signals, field_names(signals)))]
    return {"format_version": str(FORMAT_VERSION), "signals": json.dumps(rows), "rate_hz": str(rate_hz),
            "dt_s": repr(1.0 / rate_hz), "start_ns": str(start_ns),
            "time": "stamp = log_time = publish_time = start_ns + (tick * 10**9) // rate_hz [ns]; "
                    "sequence = tick mod 2**32"}


def check_conversion(src: Path, dst: Path, exists_hint: str | None) -> None:
    """ValueError naming the file unless src is a file and dst can be written: its folder exists
    and it does not exist yet (exists_hint: what to do instead; None: an existing dst may be
    replaced)."""
    if exists_hint is not None and dst.exists():
        raise ValueError(f"{dst}: the output exists; {exists_hint}")
    if not dst.parent.is_dir():
        raise ValueError(f"{dst}: folder {dst.parent} does not exist")
    if not src.is_file():
        raise ValueError(f"{src}: {'not a file' if src.exists() else 'no such file'}")

def checked_layout(path, signals, rate_hz: float, metadata: dict[str, str]):
    """What a log writer needs, checked (ValueError naming the file): (path, signals as tuples,
    rate [Hz] as int, topics, start [ns since 1970] from the metadata's start_utc)."""
    path = Path(path)
    signals = tuple(tuple(s) for s in signals)
    rate = check_rate(path, rate_hz)
    check_owners(path, signals)
    check_metadata(path, metadata)
    try:
        return path, signals, rate, topics_of(signals), start_time_ns(metadata)
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None


def stamps_ns(k: np.ndarray, rate_hz: int, start_ns: int) -> np.ndarray:
    """stamp = log_time = publish_time of ticks k: start_ns + (k * 10**9) // rate_hz [ns] (int64)."""
    return start_ns + tick_time_ns(k, rate_hz)


def encode_block(path: Path, topics, k0: int, block: np.ndarray, rate_hz: int, start_ns: int):
    """(ticks, stamps [ns], [(n, size) uint8 messages per topic]) of a checked block at k0;
    ValueError naming the file for a value its field's type cannot hold."""
    k = np.arange(k0, k0 + len(block), dtype=np.int64)
    t = stamps_ns(k, rate_hz, start_ns)
    try:
        return k, t, [tp.encode(k, t, block) for tp in topics]
    except ValueError as e:
        raise ValueError(f"{path}: {e}") from None


def part_path(path: Path) -> Path:
    """Where a log is written until it is complete: NAME.mcap -> NAME.mcap.part."""
    return path.with_name(path.name + ".part")


class McapLogWriter:
    """Writes a run's log to ``path`` in blocks of ticks (see the module docstring).

    Parameters
    ----------
    path : the .mcap file; written as ``path.part`` and renamed on close.
    signals : (name, unit, owner) per log column.
    rate_hz : tick rate [Hz], a whole number (t_k = k / rate_hz).
    metadata : strings stored in the "frictionrt" metadata record; its "start_utc" (ISO 8601),
        if any, is the start of the stamps and log times (``start_time_ns``).

    Use as a context manager, or call ``close()``; either way the file is finished and renamed,
    also when the ``with`` block raises.
    """

    def __init__(self, path: str | os.PathLike, signals, rate_hz: float, metadata: dict[str, str]):
        self.path, self.signals, self.rate_hz, self.topics, self.start_ns = \
            checked_layout(path, signals, rate_hz, metadata)
        self._part = part_path(self.path)
        self._file = open(self._part, "wb")
        self._writer = Writer(self._file, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="frictionrt")
        self._channels = []
        for tp in self.topics:
            schema = self._writer.register_schema(tp.schema_name, "ros2msg", tp.schema_text)
            self._channels.append(self._writer.register_channel(tp.name, "cdr", schema))
        self._writer.add_metadata("frictionrt", dict(metadata))
        self._writer.add_metadata("signals", signals_record(self.signals, self.rate_hz, self.start_ns))
        self._k_next = 0

    def write_block(self, k0: int, block: np.ndarray) -> None:
        """Append ticks k0 .. k0 + n - 1; block is float64 (n, n_sig), row i = tick k0 + i.

        Ticks must increase from block to block (k0 >= the previous block's end); a gap (a
        dropped block) is allowed."""
        if self._file.closed:
            raise ValueError(f"{self.path}: write_block after close")
        k0, n = check_block(self.path, k0, block, len(self.signals), self._k_next)
        if n == 0:
            return
        k, t, msgs = encode_block(self.path, self.topics, k0, block, self.rate_hz, self.start_ns)
        times, seqs = t.tolist(), (k & 0xFFFFFFFF).tolist()
        streams = [(channel, m.tobytes(), tp.message_size) for tp, channel, m in zip(self.topics, self._channels, msgs)]
        add = self._writer.add_message
        for i, (t, seq) in enumerate(zip(times, seqs)):
            for channel, data, size in streams:
                a = i * size
                add(channel, t, data[a:a + size], t, seq)
        self._k_next = k0 + n

    def close(self) -> None:
        """Finish the file (summary, indexes, footer) and rename it onto ``path``. Idempotent."""
        if self._file.closed:
            return
        try:
            self._writer.finish()
        finally:
            self._file.close()
        os.replace(self._part, self.path)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()  # also on an exception: the ticks written so far stay a valid file


@dataclass(frozen=True)
class McapLog:
    """A log read back from MCAP. Columns of absent topics, and ticks a topic lacks, are NaN."""
    path: Path
    signals: tuple[tuple[str, str, str], ...]  # (name, unit, owner) per column, original names
    log: np.ndarray          # float64 (ticks, n_sig), the written column order
    k: np.ndarray            # int64 tick of each row, increasing
    rate_hz: int             # [Hz]
    metadata: dict[str, str]  # the "frictionrt" record
    topics: tuple[str, ...]  # topics present in the file, e.g. ("/sensors",)
    version: int = FORMAT_VERSION   # of the log format (0: before ROS 2 names)
    start_ns: int = 0        # stamp of tick 0 [ns since 1970-01-01 UTC] (version 0: 0)
    keyframes: KeyFrames | None = None   # the key frames (version >= 2, rt/log/keyframes.py), if it has any

    @property
    def t(self) -> np.ndarray:
        """t_k = k / rate_hz [s]."""
        return self.k / self.rate_hz

    def column(self, name: str) -> int:
        return next(i for i, (n, _, _) in enumerate(self.signals) if n == name)


def check_framing(path: Path) -> None:
    """ValueError unless the file starts and ends with the MCAP magic."""
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
        if head != MAGIC:
            raise ValueError(f"{path}: not an MCAP file (no MCAP magic at the start)")
        f.seek(max(size - len(MAGIC), 0))
        if size < 2 * len(MAGIC) or f.read(len(MAGIC)) != MAGIC:
            raise ValueError(f"{path}: truncated MCAP file (no closing magic: the writer did not finish)")


def payload_rows(path: Path, tp: Topic, payloads: list[list[bytes] | np.ndarray]) -> np.ndarray:
    """(n, message_size) uint8 CDR messages of one topic, given in parts: each a list of payloads
    (bytes) or a (messages, bytes) uint8 array of equally long ones; ValueError naming the file
    if one has another size or is not little-endian CDR."""
    size = tp.message_size
    rows = []
    for part in payloads:
        if isinstance(part, np.ndarray):
            if part.shape[1] != size:
                part = np.zeros((len(part), 0), np.uint8)  # the length check below names it
            rows.append(part)
            continue
        buf = b"".join(part)
        if len(buf) != len(part) * size:
            rows.append(np.zeros((len(part), 0), np.uint8))
            continue
        rows.append(np.frombuffer(buf, dtype=np.uint8).reshape(len(part), size))
    if any(r.shape[1] != size for r in rows):
        raise ValueError(f"{path}: {tp.name} messages are not all {size} bytes (the schema's {len(tp.schema_fields)} "
                         "fields)")
    rows = np.concatenate(rows) if rows else np.zeros((0, size), np.uint8)
    if np.any(rows[:, :4] != np.frombuffer(CDR_LE, dtype=np.uint8)):
        raise ValueError(f"{path}: {tp.name} has messages that are not little-endian CDR")
    return rows


def ticks_of_times(times: np.ndarray, rate_hz: int) -> np.ndarray | None:
    """Version 0: the ticks k of log times (uint64 [ns]) = (k * 10**9) // rate_hz, i.e.
    k = ceil(t rate / 10**9); None if a time lies beyond the last representable tick."""
    if len(times) and times.max() > tick_time_ns(MAX_TICK, rate_hz):
        return None
    t = times.astype(np.int64)
    return -((-t * rate_hz) // 10**9)


def _ticks(path: Path, tp: Topic, k: np.ndarray | None, times: np.ndarray, seqs: np.ndarray,
           rate_hz: int) -> np.ndarray:
    """Ticks of one topic's messages, checked increasing: the tick field, or (version 0, k None)
    from the log times, checked against the time rule and the sequence numbers."""
    if k is None:
        k = ticks_of_times(times, rate_hz)
        if k is None:
            raise ValueError(f"{path}: {tp.name} has log times beyond the last representable tick")
        if np.any(tick_time_ns(k, rate_hz) != times.astype(np.int64)) or \
                np.any((k & 0xFFFFFFFF) != seqs.astype(np.int64)):
            raise ValueError(f"{path}: {tp.name} has log times or sequence numbers off the tick grid of {rate_hz} Hz")
    dk = np.diff(k)
    if np.any(dk == 0):
        raise ValueError(f"{path}: {tp.name} has duplicated ticks (first k = {int(k[1:][dk == 0][0])})")
    if np.any(dk < 0):
        raise ValueError(f"{path}: {tp.name} ticks are not increasing (k = {int(k[1:][dk < 0][0])} after a later tick)")
    return k


def record_layout(rec: dict[str, str]):
    """(version, signals, fields, types, rate [Hz], start [ns]) of a "signals" metadata record;
    ValueError saying what is wrong."""
    try:
        version = int(rec.get("format_version", "0"))
    except ValueError:
        raise ValueError(f"the 'signals' record's format_version {rec['format_version']!r} is not a "
                         "whole number") from None
    if not 0 <= version <= FORMAT_VERSION:
        raise ValueError(f"log format version {version}: this frictionrt reads versions 0 to {FORMAT_VERSION}")
    rows = json.loads(rec["signals"])
    if not isinstance(rows, list) or not rows:
        raise ValueError("the 'signals' record lists no signals (it must be a JSON list of {name, field, type, "
                         "unit, owner, column})")
    signals = tuple((str(r["name"]), str(r["unit"]), str(r["owner"])) for r in rows)
    fields = tuple(str(r["field"]) for r in rows)
    types = tuple(str(r["type"]) if version >= 1 else "float64" for r in rows)
    if [r["column"] for r in rows] != list(range(len(rows))) or \
            (version >= 1 and fields != field_names(signals)) or any(t not in CDR_TYPES for t in types):
        raise ValueError("the 'signals' record's columns, field names or types are inconsistent (fields: "
                         "frictionrt.rt.log.registry.ros2_field)")
    try:
        rate = float(rec["rate_hz"])
        start = int(rec.get("start_ns", "0"))
    except ValueError:
        rate, start = math.nan, 0
    if not (math.isfinite(rate) and rate > 0 and rate.is_integer()):
        raise ValueError(f"the 'signals' record's rate_hz {rec['rate_hz']!r} is not a positive whole number of Hz")
    return version, signals, fields, types, int(rate), start


def schema_layout(schemas: dict[str, object]):
    """(signals, fields, types) of a file without the "signals" record, from the schemas of the
    known topics (``schemas``: topic -> mcap Schema): each must start with stamp and tick; the
    other fields are the signals (``frictionrt.rt.log.registry.signal_name``; units the registry's, "" if it
    does not know one). ValueError saying what is wrong."""
    signals, fields, types = [], [], []
    for owner in OWNERS:
        schema = schemas.get("/" + owner)
        if schema is None:
            continue
        parsed = parse_schema(schema.data)
        if parsed[:2] != [(TIME_TYPE, "stamp"), ("int64", "tick")]:
            raise ValueError(f"/{owner}: a file without the 'signals' record must start each message with "
                             f"'{TIME_TYPE} stamp' and 'int64 tick' (docs/data-format.md)")
        for typ, field in parsed[2:]:
            if field in RESERVED or typ == TIME_TYPE:
                raise ValueError(f"/{owner}: field {field} ({typ}) is not a signal")
            name = signal_name(field, owner)
            e = entry_of(owner, name)
            signals.append((name, "" if e is None else e.unit, owner))
            fields.append(field)
            types.append(typ)
    if not signals:
        raise ValueError(f"no 'signals' record and none of the topics {['/' + o for o in OWNERS]}")
    return tuple(signals), tuple(fields), tuple(types)


def file_topics(meta: dict, schemas: dict[str, object]):
    """(version, signals, rate [Hz], start [ns] or None, {topic: Topic}) of a file from its
    metadata records and the schemas of its topics (topic -> mcap Schema): the "signals" record,
    or without it ``schema_layout`` at DEFAULT_RATE_HZ, start None (the first message's)."""
    rec = meta.get("signals")
    if rec is not None:
        version, signals, fields, types, rate, start = record_layout(rec)
    else:
        (signals, fields, types), version, rate, start = schema_layout(schemas), FORMAT_VERSION, DEFAULT_RATE_HZ, None
    for _, _, o in signals:
        if o not in OWNERS:
            raise ValueError(f"unknown signal owner {o!r}; owners are {list(OWNERS)}")
    topics = topics_of(signals, fields, types, stamped=version >= 1)
    return version, signals, rate, start, {tp.name: tp for tp in topics}


def iter_messages(reader):
    """The mcap library's message iteration (any valid MCAP), as ``chunk_messages`` parts."""
    for schema, channel, msg in reader.iter_messages(log_time_order=False):
        yield (schema, channel), ([msg.data], np.array([msg.log_time], np.uint64),
                                  np.array([msg.sequence], np.uint64))


_RECORD = struct.Struct("<BQ")   # opcode, content length
_CHUNK_HEAD = struct.Struct("<BQQQQI")  # opcode, length, start, end, uncompressed size, crc
_MESSAGE = 0x05
_MSG_HEAD = 22                    # channel u16, sequence u32, log_time u64, publish_time u64


def _gather(buf: np.ndarray, offsets: np.ndarray, nbytes: int) -> np.ndarray:
    """(len(offsets), nbytes) uint8 rows buf[o:o + nbytes]."""
    return buf[offsets[:, None] + np.arange(nbytes)]


def chunk_messages(f, summary):
    """Per chunk of a finished file (its summary's chunk indexes), per channel: ((schema,
    channel), (payloads (n, size) uint8, log_times uint64, sequences uint64)).

    The chunk's records are walked by their length prefixes only; the message headers and
    payloads are then gathered with numpy, so a chunk of 7000 messages costs a few ms instead
    of the mcap library's object per message (0.8 s per simulated second at 21 kHz, 6 topics).
    The uncompressed CRC is checked as the library does (0 means none)."""
    import zlib
    for ci in summary.chunk_indexes:
        f.seek(ci.chunk_start_offset)
        head = f.read(_CHUNK_HEAD.size)
        op, _, _, _, size, crc = _CHUNK_HEAD.unpack(head)
        if op != 0x06:
            raise McapError(f"no chunk record at offset {ci.chunk_start_offset}")
        (n_comp,) = struct.unpack("<I", f.read(4))
        compression = f.read(n_comp).decode()
        (n_rec,) = struct.unpack("<Q", f.read(8))
        raw = f.read(n_rec)
        if len(raw) != n_rec:
            raise EOFError(f"chunk at offset {ci.chunk_start_offset} is cut short")
        records = zstandard.ZstdDecompressor().decompress(raw, max_output_size=size) if compression else raw
        if len(records) != size or (crc != 0 and zlib.crc32(records) != crc):
            raise McapError(f"chunk at offset {ci.chunk_start_offset}: uncompressed size or CRC mismatch")
        offs, lens = [], []
        pos, end, unpack = 0, len(records), _RECORD.unpack_from
        while pos < end:
            op, n = unpack(records, pos)
            if op == _MESSAGE:
                offs.append(pos + 9)
                lens.append(n)
            pos += 9 + n
        if pos != end:
            raise McapError(f"chunk at offset {ci.chunk_start_offset}: a record runs past the chunk's end")
        if not offs:
            continue
        buf = np.frombuffer(records, np.uint8)
        offs, lens = np.array(offs, np.int64), np.array(lens, np.int64)
        if np.any(lens < _MSG_HEAD):
            raise McapError(f"chunk at offset {ci.chunk_start_offset}: a message record shorter than its header")
        head = _gather(buf, offs, _MSG_HEAD)
        ch = head[:, 0:2].copy().view("<u2").ravel()
        for cid in np.unique(ch):
            sel = ch == cid
            channel = summary.channels[int(cid)]
            schema = summary.schemas.get(channel.schema_id)
            h, o, n = head[sel], offs[sel], lens[sel] - _MSG_HEAD
            seqs = h[:, 2:6].copy().view("<u4").ravel().astype(np.uint64)
            times = h[:, 6:14].copy().view("<u8").ravel()
            if np.all(n == n[0]):
                payloads = _gather(buf, o + _MSG_HEAD, int(n[0]))
            else:
                payloads = [records[a:a + b] for a, b in zip(o + _MSG_HEAD, n)]
            yield (schema, channel), (payloads, times, seqs)


def read_attachment(path: str | os.PathLike, name: str) -> bytes | None:
    """The data of the first attachment called ``name`` in the MCAP file at path, or None if it
    has none (or the file is unreadable: ``read_mcap`` names such problems)."""
    try:
        with open(path, "rb") as f:
            for a in make_reader(f, validate_crcs=True).iter_attachments():
                if a.name == name:
                    return bytes(a.data)
    except (OSError, McapError, EOFError, ValueError, struct.error):
        return None
    return None


def read_mcap(path: str | os.PathLike) -> McapLog:
    """Read a log (any version, or a file of another tool: module docstring); ValueError naming
    the file on any problem.

    Topics other than OWNERS' are ignored; a topic of the "signals" record may be absent (its
    columns come back NaN, ``McapLog.topics`` lists the present ones)."""
    path = Path(path)
    check_framing(path)
    try:
        with open(path, "rb") as f:
            reader = make_reader(f, validate_crcs=True)
            meta = {m.name: m.metadata for m in reader.iter_metadata()}
            summary = reader.get_summary()
            fast = summary is not None and summary.chunk_indexes and \
                all(ci.compression in ("zstd", "") for ci in summary.chunk_indexes)
            parts = chunk_messages(f, summary) if fast else iter_messages(reader)
            known = {"/" + o for o in OWNERS} | {KF_TOPIC}
            data: dict[str, tuple[list, list, list]] = {}
            schemas: dict[str, object] = {}
            for (schema, channel), (payloads, times, seqs) in parts:
                if channel.topic not in known:
                    continue
                if channel.topic not in schemas:
                    if schema is None or schema.encoding != "ros2msg" or channel.message_encoding != "cdr":
                        raise ValueError(f"{path}: {channel.topic} must have a ros2msg schema and cdr messages")
                    schemas[channel.topic] = schema
                acc = data.setdefault(channel.topic, ([], [], []))
                for lst, part in zip(acc, (payloads, times, seqs)):
                    lst.append(part)
        version, signals, rate_hz, start, topics = file_topics(meta, schemas)
    except (McapError, zstandard.ZstdError, OSError, EOFError, KeyError, TypeError, struct.error,
            json.JSONDecodeError, UnicodeDecodeError) as e:   # the last: a name or string field not UTF-8
        raise ValueError(f"{path}: unreadable MCAP log ({type(e).__name__}: {e})") from e
    except ValueError as e:
        raise ValueError(e.args[0] if str(e).startswith(str(path)) else f"{path}: {e}") from None
    keyframes = None
    if KF_TOPIC in data and version >= 2 and KF_RECORD in meta:
        try:
            codec = KeyframeCodec.from_record(meta[KF_RECORD])
            if schemas[KF_TOPIC].data != codec.schema_text:
                raise ValueError(f"the schema of {KF_TOPIC} does not match the 'keyframes' record")
            keyframes = codec.decode(payload_rows(path, _KfTopic(codec), data[KF_TOPIC][0]))
        except ValueError as e:
            raise ValueError(e.args[0] if str(e).startswith(str(path)) else f"{path}: {e}") from None
    present = [name for name in topics if name in data]
    ks, values = {}, {}
    for name in present:
        tp = topics[name]
        try:
            same = parse_schema(schemas[name].data) == tp.schema_fields
        except ValueError:
            same = False
        if not same or schemas[name].name != tp.schema_name:
            raise ValueError(f"{path}: the schema of {name} does not match the 'signals' record")
        k, _, values[name] = tp.decode(payload_rows(path, tp, data[name][0]))
        times = np.concatenate(data[name][1])
        ks[name] = _ticks(path, tp, k, times, np.concatenate(data[name][2]), rate_hz)
        if start is None and len(times):
            start = int(times[0]) - int(tick_time_ns(ks[name][0], rate_hz))
    k = np.unique(np.concatenate(list(ks.values()))) if ks else np.zeros(0, dtype=np.int64)
    log = np.full((len(k), len(signals)), np.nan)
    for name in present:
        log[np.searchsorted(k, ks[name])[:, None], topics[name].columns] = values[name]
    return McapLog(path, signals, log, k, rate_hz, dict(meta.get("frictionrt", {})), tuple(present), version,
                   start or 0, keyframes)


@dataclass(frozen=True)
class _KfTopic:
    """What ``payload_rows`` reads of a topic, for the key frames."""
    codec: KeyframeCodec
    name: str = KF_TOPIC
    schema_fields: tuple = ()

    @property
    def message_size(self) -> int:
        return self.codec.message_size
