"""Recovering a run log that was never finished (the process was killed while writing it).

``McapBlockWriter`` (rt/log/writer.py) writes ``NAME.mcap.part`` as: magic, header, schemas,
channels, the "frictionrt" and "signals" metadata records (all at open, before any data), then
per chunk of ``chunk_ticks`` whole ticks one zstd chunk record and its message index records;
the summary and footer only on close. A ``kill -9`` therefore leaves a file whose data section
is intact up to the last record the writer had handed to the OS, possibly followed by the first
bytes of a record that was being written. What it had not handed over (the open chunk, built in
memory, and the rows the loop had run but the writer thread had not taken yet) is not in the
file and cannot be recovered.

``recover(src, dst)``:

1. walks the records from the start with mcap's ``StreamReader`` (chunks kept whole,
   ``emit_chunks=True``); every chunk is decompressed and its CRC-32 checked. The walk stops at
   the first record that is cut short or corrupt (or at the data end of a finished file);
   ``end`` is the offset just after the last good record.
2. copies bytes ``[0, end)`` to a temporary file and closes it with a data end record, a
   summary holding only metadata indexes, and a footer (a valid MCAP file without chunk
   indexes), so ``frictionrt.rt.log.mcap_log.read_mcap`` reads and
   checks it exactly as it reads any log (schemas against the "signals" record, the tick grid,
   CDR); its errors name the source file.
3. writes the ticks to ``dst`` with ``McapBlockWriter`` (schemas, channels, chunks, indexes and
   summary as the run's writer would have written them, ``.part`` renamed at the end), with the
   "frictionrt" record, every other metadata record of the source in its order, and a
   "frictionrt.recover" record (source, ticks, what was lost) and the key frames of the salvaged
   ticks (format version 2), so that replay restarts after the gaps. Gaps (dropped blocks of a
   paced run) stay gaps.

The output has the source's schemas and channels only if the source carries every topic of its
"signals" record (as ``simulate --out`` logs do): the block writer writes all of them each tick,
so a file with some topics absent is refused rather than filled with NaN messages.
"""
from __future__ import annotations

import json
import os
import struct
import time
from dataclasses import dataclass, field
from pathlib import Path

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Attachment, Chunk, DataEnd, Footer, Metadata, MetadataIndex
from mcap.stream_reader import StreamReader, get_chunk_data_stream

from frictionrt.rt.log.keyframes import RECORD as KF_RECORD
from frictionrt.rt.log.mcap_log import MAGIC, check_conversion, read_mcap, tick_runs, topics_of
from frictionrt.rt.log.writer import McapBlockWriter

CHUNK_HEAD = struct.Struct("<BQQQ")  # opcode, record length, message start time, message end time [ns]


@dataclass
class Scan:
    """What a walk over a (possibly cut) MCAP file found."""
    size: int                  # file size [B]
    end: int = 0               # offset just after the last good record [B]
    chunks: int = 0            # complete chunks with a good CRC
    finished: bool = False     # the walk reached a data end or footer record (the writer had closed the file)
    stop: str = ""             # why the walk stopped before a data end record
    cut_opcode: int | None = None   # opcode of the record cut short, if its first byte is there
    cut_times_ns: tuple[int, int] | None = None   # a cut chunk's message start, end time, if readable
    chunk_times_ns: list[tuple[int, int]] = field(default_factory=list)   # per complete chunk
    metadata: list[Metadata] = field(default_factory=list)
    metadata_at: list[tuple[int, int]] = field(default_factory=list)   # (offset, length) of each [B]
    attachments: list[Attachment] = field(default_factory=list)   # e.g. the run's design (rt.log.design_record)

    @property
    def lost_bytes(self) -> int:
        return 0 if self.finished else self.size - self.end


def scan(path: Path) -> Scan:
    """Walk the records of ``path`` up to the first incomplete or corrupt one (module docstring,
    step 1). ValueError naming the file if it is not an MCAP file."""
    s = Scan(size=path.stat().st_size)
    with open(path, "rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            raise ValueError(f"{path}: not an MCAP file (no MCAP magic at the start); "
                             "recover reads files written by frictionrt simulate --out")
        f.seek(0)
        s.end = len(MAGIC)
        records = StreamReader(f, emit_chunks=True).records
        while True:
            try:
                rec = next(records)
                if isinstance(rec, Chunk):
                    get_chunk_data_stream(rec, validate_crc=True)   # decompress, check the CRC-32
            except (McapError, zstandard.ZstdError, struct.error, ValueError, EOFError) as exc:
                s.stop = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
                break
            if isinstance(rec, (DataEnd, Footer)):
                s.finished = True
                break
            start, s.end = s.end, f.tell()
            if isinstance(rec, Chunk):
                s.chunks += 1
                s.chunk_times_ns.append((rec.message_start_time, rec.message_end_time))
            elif isinstance(rec, Metadata):
                s.metadata.append(rec)
                s.metadata_at.append((start, s.end - start))
            elif isinstance(rec, Attachment):
                s.attachments.append(rec)
        if not s.finished and s.end < s.size:
            f.seek(s.end)
            head = f.read(CHUNK_HEAD.size)
            s.cut_opcode = head[0] if head else None
            if s.cut_opcode == Opcode.CHUNK and len(head) == CHUNK_HEAD.size:
                s.cut_times_ns = CHUNK_HEAD.unpack(head)[2:]
    return s


def _closed_copy(src: Path, s: Scan, tmp: Path) -> None:
    """Bytes [0, s.end) of src, then a data end record, a summary of metadata indexes only (so
    mcap's reader finds the metadata without a pass over the chunks; without chunk indexes it
    reads the messages in one pass), a footer and the magic."""
    rb = RecordBuilder()
    DataEnd(data_section_crc=0).write(rb)
    summary_start = s.end + rb.count
    for m, (offset, length) in zip(s.metadata, s.metadata_at):
        MetadataIndex(offset=offset, length=length, name=m.name).write(rb)
    Footer(summary_start=summary_start, summary_offset_start=0, summary_crc=0).write(rb)
    with open(src, "rb") as fi, open(tmp, "wb") as fo:
        left = s.end
        while left > 0:
            buf = fi.read(min(left, 1 << 24))
            if not buf:
                raise ValueError(f"{src}: the file shrank while it was being read")
            fo.write(buf)
            left -= len(buf)
        fo.write(rb.end() + MAGIC)


def _tick(t_ns: int, rec) -> int:
    """k of a log time t = start_ns + (k * 10**9) // rate_hz [ns] of the log rec (rt.log.mcap_log's time rule)."""
    return -((-(t_ns - rec.start_ns) * rec.rate_hz) // 10**9)


def recover(src: str | os.PathLike, dst: str | os.PathLike, overwrite: bool = False) -> dict:
    """Recover the complete chunks of ``src`` (e.g. ``NAME.mcap.part`` after a kill) into a
    finished, indexed MCAP log ``dst`` (module docstring).

    Returns the report: ticks, first_tick, last_tick, missing_ticks (gaps inside), chunks,
    chunk_ticks (ticks per complete chunk: at most that many of the open chunk were lost besides
    what the file shows), finished (src had been closed), lost_bytes (after the last good record),
    lost_record ("chunk", ..., or null), lost_chunk_ticks ([k0, k1] of a chunk cut short, or null),
    stop (why the walk ended), metadata (record names copied), seconds (wall time).
    ValueError naming the file: dst exists (replaced only if ``overwrite``; never src), src missing
    or not MCAP, no complete chunk, not a frictionrt log, topics missing."""
    t0 = time.perf_counter()
    src, dst = Path(src), Path(dst)
    if dst.resolve() == src.resolve():
        raise ValueError(f"{dst}: is the input; give another name for the recovered log")
    check_conversion(src, dst, None if overwrite else "give a new file name or pass --force to replace it")
    s = scan(src)
    if s.chunks == 0:
        raise ValueError(f"{src}: no complete chunk in the file ({s.size} B; {s.stop or 'no data'}): nothing to "
                         "recover")
    tmp = dst.with_name(dst.name + ".scan.tmp")
    try:
        _closed_copy(src, s, tmp)
        try:
            rec = read_mcap(tmp)
        except ValueError as exc:
            raise ValueError(str(exc).replace(str(tmp), str(src))) from None
    finally:
        tmp.unlink(missing_ok=True)
    missing = sorted({tp.name for tp in topics_of(rec.signals)} - set(rec.topics))
    if missing:
        raise ValueError(f"{src}: topics {missing} of the 'signals' record are absent; recover rebuilds "
                         "complete run logs (frictionrt simulate --out) only")
    chunk_ticks = [_tick(b, rec) - _tick(a, rec) + 1 for a, b in s.chunk_times_ns]
    report = {
        "input": str(src), "output": str(dst), "ticks": len(rec.k),
        "first_tick": int(rec.k[0]), "last_tick": int(rec.k[-1]),
        "missing_ticks": int(rec.k[-1] - rec.k[0] + 1 - len(rec.k)), "chunks": s.chunks,
        "chunk_ticks": max(chunk_ticks), "finished": s.finished, "lost_bytes": s.lost_bytes,
        "lost_record": None if s.cut_opcode is None else _opcode_name(s.cut_opcode),
        "lost_chunk_ticks": None if s.cut_times_ns is None else [_tick(t, rec) for t in s.cut_times_ns],
        "stop": s.stop if not s.finished else "",
        "metadata": [m.name for m in s.metadata if m.name != "signals"],
        "keyframes": 0 if rec.keyframes is None else int(sum(rec.keyframes.k <= rec.k[-1])),
    }
    out = dst.with_name(dst.name + ".recover.tmp")  # its .part is never src (NAME.mcap.part -> NAME.mcap)
    try:
        kf = rec.keyframes
        with McapBlockWriter(out, rec.signals, rec.rate_hz, rec.metadata, kf.codec if kf is not None else None) as w:
            for m in s.metadata:
                if m.name not in ("frictionrt", "signals", KF_RECORD):
                    w.add_metadata(m.name, m.metadata)
            w.add_metadata("frictionrt.recover", {
                "source": str(src), "ticks": str(report["ticks"]), "last_tick": str(report["last_tick"]),
                "lost_bytes": str(report["lost_bytes"]), "report": json.dumps(report)})
            for att in s.attachments:
                w.add_attachment(att.name, att.media_type, bytes(att.data))
            if kf is not None:   # the key frames of the salvaged ticks (each goes into its tick's chunk)
                w.write_keyframes(kf.f, kf.i)
            for a, b in tick_runs(rec.k):
                w.write_block(int(rec.k[a]), rec.log[a:b])
        os.replace(out, dst)
    finally:
        out.unlink(missing_ok=True)   # only left if writing failed
    report["seconds"] = time.perf_counter() - t0
    return report


def _opcode_name(op: int) -> str:
    try:
        return Opcode(op).name.lower()
    except ValueError:
        return f"unknown opcode {op:#x}"
