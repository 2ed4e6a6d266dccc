"""Run logs as MCAP files: one ROS 2 (CDR) topic per owning package, encoded with numpy in blocks.

A run's log is a float64 array (ticks, n_sig) whose columns are ``signals`` = (name, unit, owner)
(``rt.loop.loop_signals``). The file holds:

    topics     /rt /sensors /observer /tracking /actuator /plant (those owning a column), in that
               order; one message per tick per topic, messages interleaved tick by tick
    schema     per topic, encoding "ros2msg", name "frictionrt/msg/<Owner>" (e.g.
               frictionrt/msg/Plant), text one line "float64 FIELD" per signal of the owner in
               column order, so Foxglove plots /tracking.F_set_filtered by name
    message    encoding "cdr", little endian: the encapsulation header 00 01 00 00, then the
               owner's m float64 fields. CDR aligns relative to the end of the header, so the
               fields sit at 8-byte offsets without padding: 4 + 8 m bytes, bit-exact copies
               of the log (NaN payloads, -0.0, inf and denormals included)
    times      log_time = publish_time = (k * 10**9) // rate_hz [ns], the floor of t_k = k / rate_hz
               in exact integer arithmetic (k round(1e9 dt) would drift: 1/21000 s is not a
               whole number of ns); sequence = k mod 2**32 (MCAP's field is uint32). The reader
               recovers k = ceil(log_time rate_hz / 10**9) and checks both. rate_hz must be a
               whole number of Hz; ticks up to 2**63 / 10**9 (5 days at 21 kHz)
    chunks     zstd, CHUNK_BYTES = 1 MiB uncompressed (17 per simulated second at 21 kHz; 4 or 16 MiB
               compress no better: the float64 noise dominates)
    metadata   record "frictionrt": the caller's strings (resolved configuration TOML, package
               versions, seed, start time, command line); record "signals": "signals" = JSON
               list of {name, field, unit, owner, column}, "rate_hz", "dt_s", "time" (the rule
               above)

Field names are the signal names where they are valid ros2msg field names as Foxglove parses
them, ``[A-Za-z][A-Za-z0-9_]*`` (rosidl's stricter lower-case rule is not applied: F_N1 stays
F_N1). Other names are sanitised deterministically (invalid characters -> "_", a leading
non-letter gets "f_", a clash gets "_2", "_3", ...); the original name stays in the "signals"
record and ``read_mcap`` returns it.

Nothing is half-written: the writer writes ``NAME.mcap.part`` and renames it onto ``NAME.mcap``
on close. An exception inside ``with McapLogWriter(...)`` (a crash of the run, Ctrl-C) still
closes the file, so everything written up to then is a valid, readable MCAP file, and then
propagates. Only a killed process leaves a ``.part`` file behind (``frictionrt recover``,
rt/recover.py, salvages its complete chunks).

``read_mcap`` walks each chunk's records by their length prefixes and gathers the message
headers and payloads with numpy (``_chunk_messages``; files without chunk indexes go through the
mcap library's reader), then decodes each topic with one view over its payload rows.
"""
from __future__ import annotations

import json
import math
import os
import re
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Self

import numpy as np
import zstandard
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

OWNERS = ("rt", "sensors", "observer", "tracking", "actuator", "plant")
CDR_LE = b"\x00\x01\x00\x00"   # CDR encapsulation header: plain CDR, little endian
CHUNK_BYTES = 1 << 20          # uncompressed chunk size [B]
MAGIC = b"\x89MCAP0\r\n"
FIELD_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
MAX_TICK = (2**63 - 1) // 10**9  # k * 10**9 must fit int64


def field_names(signals) -> tuple[str, ...]:
    """ros2msg field name of each signal (see the module docstring for the sanitising rule)."""
    used: set[str] = set()
    out = []
    for name, _, _ in signals:
        base = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if not FIELD_RE.match(base):
            base = "f_" + base
        field, n = base, 1
        while field in used:
            n += 1
            field = f"{base}_{n}"
        used.add(field)
        out.append(field)
    return tuple(out)


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


@dataclass(frozen=True)
class Topic:
    """One owner's topic: its log columns and ros2msg schema."""
    owner: str
    columns: np.ndarray   # int64 log columns, in order
    fields: tuple[str, ...]

    @property
    def name(self) -> str:
        return "/" + self.owner

    @property
    def schema_name(self) -> str:
        return schema_name(self.owner)

    @property
    def schema_text(self) -> bytes:
        return "".join(f"float64 {f}\n" for f in self.fields).encode()

    @property
    def message_size(self) -> int:
        return len(CDR_LE) + 8 * len(self.fields)


def check_owners(path: Path, signals) -> None:
    """ValueError naming the file if a signal's owner is not one of OWNERS."""
    unknown = sorted({o for _, _, o in signals} - set(OWNERS))
    if unknown:
        raise ValueError(f"{path}: unknown signal owner(s) {unknown}; owners are {list(OWNERS)}")


def topics_of(signals) -> tuple[Topic, ...]:
    """The topics of a signal layout (owners checked), in OWNERS order."""
    fields = field_names(signals)
    owners = [o for _, _, o in signals]
    out = []
    for owner in OWNERS:
        cols = [c for c, o in enumerate(owners) if o == owner]
        if cols:
            out.append(Topic(owner, np.array(cols, dtype=np.int64), tuple(fields[c] for c in cols)))
    return tuple(out)


def signals_record(signals, rate_hz: int) -> dict[str, str]:
    """The "signals" metadata record: the layout, the rate and the time rule."""
    rows = [{"name": n, "field": f, "unit": u, "owner": o, "column": c}
            for c, ((n, u, o), f) in enumerate(zip(signals, field_names(signals)))]
    return {"signals": json.dumps(rows), "rate_hz": str(rate_hz), "dt_s": repr(1.0 / rate_hz),
            "time": "log_time = publish_time = (k * 10**9) // rate_hz [ns]; sequence = k mod 2**32"}


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
    rate [Hz] as int, topics)."""
    path = Path(path)
    signals = tuple(tuple(s) for s in signals)
    rate = check_rate(path, rate_hz)
    check_owners(path, signals)
    check_metadata(path, metadata)
    return path, signals, rate, topics_of(signals)

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
    metadata : strings stored in the "frictionrt" metadata record.

    Use as a context manager, or call ``close()``; either way the file is finished and renamed,
    also when the ``with`` block raises.
    """

    def __init__(self, path: str | os.PathLike, signals, rate_hz: float, metadata: dict[str, str]):
        self.path, self.signals, self.rate_hz, self.topics = checked_layout(path, signals, rate_hz, metadata)
        self._part = part_path(self.path)
        self._file = open(self._part, "wb")
        self._writer = Writer(self._file, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(library="frictionrt")
        self._channels = []
        for tp in self.topics:
            schema = self._writer.register_schema(tp.schema_name, "ros2msg", tp.schema_text)
            self._channels.append(self._writer.register_channel(tp.name, "cdr", schema))
        self._writer.add_metadata("frictionrt", dict(metadata))
        self._writer.add_metadata("signals", signals_record(self.signals, self.rate_hz))
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
        k = np.arange(k0, k0 + n, dtype=np.int64)
        times = tick_time_ns(k, self.rate_hz).tolist()
        seqs = (k & 0xFFFFFFFF).tolist()
        streams = []
        for tp, channel in zip(self.topics, self._channels):
            msg = np.empty((n, tp.message_size), dtype=np.uint8)
            msg[:, :4] = np.frombuffer(CDR_LE, dtype=np.uint8)
            msg[:, 4:] = np.ascontiguousarray(block[:, tp.columns], dtype="<f8").view(np.uint8)
            streams.append((channel, msg.tobytes(), tp.message_size))
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

    @property
    def t(self) -> np.ndarray:
        """t_k = k / rate_hz [s]."""
        return self.k / self.rate_hz

    def column(self, name: str) -> int:
        return next(i for i, (n, _, _) in enumerate(self.signals) if n == name)


def _check_framing(path: Path) -> None:
    """ValueError unless the file starts and ends with the MCAP magic."""
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(len(MAGIC))
        if head != MAGIC:
            raise ValueError(f"{path}: not an MCAP file (no MCAP magic at the start)")
        f.seek(max(size - len(MAGIC), 0))
        if size < 2 * len(MAGIC) or f.read(len(MAGIC)) != MAGIC:
            raise ValueError(f"{path}: truncated MCAP file (no closing magic: the writer did not finish)")


def _decode_topic(path: Path, tp: Topic, payloads: list[list[bytes] | np.ndarray]) -> np.ndarray:
    """(n, m) float64 values of one topic's CDR payloads, given in parts: each a list of
    payloads (bytes) or a (messages, bytes) uint8 array of equally long ones."""
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
        raise ValueError(f"{path}: {tp.name} messages are not all {size} bytes (schema has {len(tp.fields)} fields)")
    rows = np.concatenate(rows) if rows else np.zeros((0, size), np.uint8)
    if np.any(rows[:, :4] != np.frombuffer(CDR_LE, dtype=np.uint8)):
        raise ValueError(f"{path}: {tp.name} has messages that are not little-endian CDR")
    return np.ascontiguousarray(rows[:, 4:]).view("<f8").astype(np.float64, copy=False)


def _ticks(path: Path, tp: Topic, times: np.ndarray, seqs: np.ndarray, rate_hz: int) -> np.ndarray:
    """Ticks of one topic's messages from their log times (uint64 [ns]), checked against the time rule."""
    if times.max() > tick_time_ns(MAX_TICK, rate_hz):
        raise ValueError(f"{path}: {tp.name} has log times beyond the last representable tick")
    t = times.astype(np.int64)
    k = -((-t * rate_hz) // 10**9)   # ceil(t rate / 1e9): t = floor(k 1e9 / rate)
    if np.any(tick_time_ns(k, rate_hz) != t) or np.any((k & 0xFFFFFFFF) != seqs.astype(np.int64)):
        raise ValueError(f"{path}: {tp.name} has log times or sequence numbers off the tick grid of {rate_hz} Hz")
    dk = np.diff(k)
    if np.any(dk == 0):
        raise ValueError(f"{path}: {tp.name} has duplicated ticks (first k = {int(k[1:][dk == 0][0])})")
    if np.any(dk < 0):
        raise ValueError(f"{path}: {tp.name} ticks are not increasing (k = {int(k[1:][dk < 0][0])} after a later tick)")
    return k


def _iter_messages(reader):
    """The mcap library's message iteration (any valid MCAP), as ``_chunk_messages`` parts."""
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


def _chunk_messages(f, summary):
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
    """Read a log written by ``McapLogWriter``; ValueError naming the file on any problem.

    Topics not in the "signals" record are ignored; a topic of the record may be absent (its
    columns come back NaN, ``McapLog.topics`` lists the present ones)."""
    path = Path(path)
    _check_framing(path)
    try:
        with open(path, "rb") as f:
            reader = make_reader(f, validate_crcs=True)
            meta = {m.name: m.metadata for m in reader.iter_metadata()}
            if "signals" not in meta:
                raise ValueError(f"{path}: no 'signals' metadata record: not a frictionrt log")
            rec = meta["signals"]
            rows = json.loads(rec["signals"])
            if not isinstance(rows, list) or not rows:
                raise ValueError(f"{path}: the 'signals' record lists no signals (it must be a JSON list of "
                                 "{name, field, unit, owner, column})")
            signals = tuple((r["name"], r["unit"], r["owner"]) for r in rows)
            if [r["column"] for r in rows] != list(range(len(rows))) or \
                    [r["field"] for r in rows] != list(field_names(signals)):
                raise ValueError(f"{path}: the 'signals' record's columns or field names are inconsistent")
            try:
                rate_hz = check_rate(path, float(rec["rate_hz"]))
            except ValueError:
                raise ValueError(f"{path}: the 'signals' record's rate_hz {rec['rate_hz']!r} is not a positive "
                                 "whole number of Hz") from None
            check_owners(path, signals)
            topics = {tp.name: tp for tp in topics_of(signals)}
            summary = reader.get_summary()
            fast = summary is not None and summary.chunk_indexes and \
                all(ci.compression in ("zstd", "") for ci in summary.chunk_indexes)
            parts = _chunk_messages(f, summary) if fast else _iter_messages(reader)
            data: dict[str, tuple[list, list, list]] = {}
            checked: set[int] = set()   # channel ids whose schema matched
            for (schema, channel), (payloads, times, seqs) in parts:
                tp = topics.get(channel.topic)
                if tp is None:
                    continue
                if channel.id not in checked:
                    if schema is None or schema.encoding != "ros2msg" or channel.message_encoding != "cdr" \
                            or schema.name != tp.schema_name or schema.data != tp.schema_text:
                        raise ValueError(f"{path}: the schema of {tp.name} does not match the 'signals' record")
                    checked.add(channel.id)
                acc = data.setdefault(channel.topic, ([], [], []))
                for lst, part in zip(acc, (payloads, times, seqs)):
                    lst.append(part)
    except (McapError, zstandard.ZstdError, OSError, EOFError, KeyError, TypeError, struct.error,
            json.JSONDecodeError, UnicodeDecodeError) as e:   # the last: a name or string field not UTF-8
        raise ValueError(f"{path}: unreadable MCAP log ({type(e).__name__}: {e})") from e
    present = [name for name in topics if name in data]
    ks = {name: _ticks(path, topics[name], np.concatenate(data[name][1]), np.concatenate(data[name][2]), rate_hz)
          for name in present}
    k = np.unique(np.concatenate(list(ks.values()))) if ks else np.zeros(0, dtype=np.int64)
    log = np.full((len(k), len(signals)), np.nan)
    for name in present:
        tp = topics[name]
        log[np.searchsorted(k, ks[name])[:, None], tp.columns] = _decode_topic(path, tp, data[name][0])
    return McapLog(path, signals, log, k, rate_hz, dict(meta.get("frictionrt", {})), tuple(present))

