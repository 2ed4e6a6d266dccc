"""The log writer of a run: a thread that drains the loop's log in blocks to MCAP and .rrd.

The loop (``frictionrt.rt.loop.driver.run``) writes tick k into row (k - k0) mod R of its log and then
increments ``clk[CLK_TICKS]``; ticks below k0 + that counter are complete. The writer thread
(``LogWriter``, started by ``run(..., writer=...)``) polls the counter every ``POLL_S``, copies
complete rows out in blocks of ``block_ticks`` (default 2100 ticks = 0.1 s simulated), folds
each block into the run's digest (``frictionrt.rt.loop.digest``: the summary's whole-run figures) and hands it
to its sinks: an MCAP file (``McapBlockWriter``) and, unless left out, an .rrd recording
(``frictionrt.rt.log.rrd_log.RrdLogWriter``, fed in batches of ``RRD_BATCH_TICKS`` because each rerun call has
a fixed cost per entity). It never touches the loop's state, and the loop never reads anything
the writer writes but the count below (STYLE.md section 3).

**The ring.** A run with a writer preallocates R = ``ring_ticks`` rows (``ring_s`` rounded to
whole blocks, default ``RING_S`` = 1 s = 21000 rows, 14 MB at 85 signals), not one row per
tick, so its memory does not grow with its length. After copying a block out of the ring the
writer sets ``clk[CLK_WRITTEN]`` to the tick after it (the rows before may be overwritten):

- offline (``paced=False``): nothing is ever dropped. Before tick k the compiled loop spins
  (nogil, re-reading the count around a clock call) while k - ``clk[CLK_WRITTEN]`` >= R, so an
  offline run proceeds at the writer's pace once it is R ticks ahead; when the loop is done the
  writer writes the rest before ``finish()`` returns. A writer that stops (an error, the end of
  its thread) sets the count to ``frictionrt.rt.common.clock.NO_WAIT`` so that the loop never waits for it again.
- paced: a real-time loop never waits. Row i is overwritten once the loop has begun tick
  i + R; a block whose first row is (the loop's count - i >= R, or R + 1 once the loop has
  ended: ``finish()`` was called, or the count has reached the run's length, which ``run``
  passes to ``start``) is skipped and counted (``dropped_blocks``), checked before copying and
  again after the copy (a block overwritten while being copied is dropped too). Dropped blocks are whole
  blocks; the MCAP file then has a gap in its ticks, and its closing metadata record
  ``frictionrt.writer`` holds the count (``run`` callers print it). The thread lowers its own
  priority (nice ``WRITER_NICE``) so that, sharing a core, the scheduler prefers the loop.

**Key frames.** With a key-frame ring (``start(..., keyframes=)``: the loop's state at the ticks
that are multiples of the interval, rt/loop/keyframe.py) the writer copies the key frames of a
block's ticks out with the block (a dropped block's go with it) and hands them to the sinks that
take them (``McapBlockWriter.write_keyframes``) before the block; the ring is sized so that a key
frame is overwritten no earlier than its tick's row.

The block handed to the sinks is a copy, so a sink may keep it (``Batched``) while the loop
overwrites the ring. ``ring_s=None``: no ring, the log holds the whole run (nothing dropped).

**Crash safety.** Signals reach only the main thread, so a Ctrl-C never interrupts a block
half-written: ``run`` turns it into the loop's stop request, then ``finish()`` makes the
thread write the complete rows it has not written yet and close both files (``.part`` renamed
onto the final name). After a Ctrl-C (the loop's stop flag is set, or the Ctrl-C arrives while
``finish()`` waits) the thread writes its backlog for at most ``INTERRUPT_DRAIN_S`` more, then
stops after the block in hand and closes the files, so the process exits promptly: an offline
run is at most its ring ahead of its writer. The files then hold ticks
0 .. written_ticks - 1 (contiguous, but for dropped blocks); the rows the loop ran beyond are
counted in ``unwritten_ticks`` (and in the closing record). A paced writer keeps up, so it loses
nothing. The thread is not a daemon, so even an exception in the main thread cannot end the
process before the files are closed. An error inside the writer (e.g. a full disk) stops the
writing, closes what it can and is kept in ``error``; the loop runs on. A killed process
(``kill -9``) leaves ``NAME.mcap.part``: ``frictionrt recover`` (rt/log/recover.py) salvages its
complete chunks.

**Why ``McapBlockWriter`` and not ``frictionrt.rt.log.mcap_log.McapLogWriter``.** Both write the same MCAP
content (topics, schemas, channels, messages with their times and sequence numbers, the
"frictionrt" and "signals" metadata records, zstd chunks of ~1 MiB; checked by
tests/test_logging_loop.py against McapLogWriter, mcap's own reader with CRC validation and
rerun's MCAP reader). McapLogWriter passes each message through mcap's Python ``Writer`` (one
``add_message`` call per message: 6 topics x 21000 messages per simulated second, 0.7-0.8 s
CPU per simulated second), 15 times the loop's own cost. McapBlockWriter builds a chunk's
records with numpy: a template of one tick's 6 message records (opcode, length, channel:
constant) is repeated over the chunk's rows once, then each block only copies its sequence
numbers, log/publish times and the topics' CDR messages (``frictionrt.rt.log.mcap_log.Topic.encode``, one
numpy structured array per topic and block) into place; the chunk is
compressed with zstd at the fast level -1 (files 2 % larger than at levels 1-3 on this float64
data, 2-4x faster) and its message indexes are numpy arrays as well: 0.05-0.06 s CPU per
simulated second (docs/loop.md, "Logging and replay"). Schema and channel records are written
in the data section before the first chunk (valid MCAP; McapLogWriter puts them inside the
first chunk) and repeated in the summary. The file's bytes do not depend on how the ticks
were split into blocks (chunks hold a fixed number of ticks).

Length: the writer thread, its ring protocol with the loop (the CLK_WRITTEN handshake), the
crash-safe finishing and the run's metadata belong together; about 30 lines over the ~500 line
guide.
"""
from __future__ import annotations

import json
import os
import struct
import sys
import threading
import time
import zlib
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Self

import numpy as np
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (Attachment, AttachmentIndex, Channel, ChunkIndex, DataEnd, Footer, Header, Metadata, MetadataIndex, Schema,
                          Statistics, SummaryOffset)

from frictionrt.rt.log.keyframes import RECORD as KF_RECORD
from frictionrt.rt.log.keyframes import SCHEMA_NAME as KF_SCHEMA
from frictionrt.rt.log.keyframes import TOPIC as KF_TOPIC
from frictionrt.rt.log.keyframes import KeyframeCodec
from frictionrt.rt.log.mcap_log import (CHUNK_BYTES, MAGIC, PROFILE, check_block, checked_layout, encode_block, part_path,
                         signals_record, stamps_ns, utc_now)

BLOCK_TICKS = 2100        # rows per block handed to the sinks (0.1 s simulated at 21 kHz)
RING_S = 1.0              # default ring of a run with a writer [s of simulated time]
RRD_BATCH_TICKS = 21000   # .rrd written in batches of this many ticks (rerun's cost per call)
POLL_S = 0.002            # the writer checks the loop's tick counter this often [s]
WRITER_NICE = 10          # paced runs: the writer thread's nice value (Linux: per thread)
INTERRUPT_DRAIN_S = 0.5   # after Ctrl-C the writer writes its backlog for at most this long [s wall], then closes
ZSTD_LEVEL = -1          # zstd "fast" level: 35 % faster than level 1, files 2 % larger (float64 noise)
VERSION_PACKAGES = ("numpy", "numba", "llvmlite", "scipy", "control", "mcap", "rerun-sdk", "zstandard", "frictionrt")
_MSG_HEAD = 1 + 8 + 2 + 4 + 8 + 8   # opcode, record length, channel id, sequence, log time, publish time


class McapBlockWriter:
    """Writes a run's log to ``path`` as MCAP, the layout of ``frictionrt.rt.log.mcap_log`` (module docstring
    there), encoded with numpy per chunk (this module's docstring).

    Same interface as ``McapLogWriter``: ``write_block(k0, block)``, ``close()``, context manager;
    written as ``path.part`` and renamed on close, also when the ``with`` block raises.
    ``add_metadata(name, record)`` adds a metadata record at any time before close."""

    def __init__(self, path: str | os.PathLike, signals, rate_hz: float, metadata: dict[str, str],
                 keyframes: KeyframeCodec | None = None):
        self.path, self.signals, self.rate_hz, self.topics, self.start_ns = \
            checked_layout(path, signals, rate_hz, metadata)
        self.keyframes = keyframes   # key frames (rt/log/keyframes.py): their channel comes after the topics'
        self._kf_pending: list[tuple[int, np.ndarray]] = []   # (tick, message) not yet in a chunk
        self._n_kf = 0
        self._part = part_path(self.path)
        # one tick's records: per topic the message record; offsets of its variable fields
        self._rec_off, off = [], 0
        for tp in self.topics:
            self._rec_off.append(off)
            off += _MSG_HEAD + tp.message_size
        self.row_bytes = off
        self.chunk_ticks = max(1, CHUNK_BYTES // self.row_bytes)
        template = np.zeros(self.row_bytes, np.uint8)
        for ch, (tp, o) in enumerate(zip(self.topics, self._rec_off), start=1):
            head = struct.pack("<BQH", Opcode.MESSAGE, _MSG_HEAD - 9 + tp.message_size, ch)
            template[o:o + 11] = np.frombuffer(head, np.uint8)
        self._buf = np.tile(template, (self.chunk_ticks, 1))   # the open chunk's records
        self._buf_k = np.empty(self.chunk_ticks, np.int64)     # its ticks
        self._fill = 0
        self._zstd = zstandard.ZstdCompressor(level=ZSTD_LEVEL)
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._attachment_indexes: list[AttachmentIndex] = []
        self._n_ticks = 0
        self._t_first = self._t_last = 0
        self._k_next = 0
        self._closed = False
        self._schemas = [Schema(id=i, name=tp.schema_name, encoding="ros2msg", data=tp.schema_text)
                         for i, tp in enumerate(self.topics, start=1)]
        self._channels = [Channel(id=i, topic=tp.name, message_encoding="cdr", schema_id=i, metadata={})
                          for i, tp in enumerate(self.topics, start=1)]
        if keyframes is not None:
            self._kf_id = len(self.topics) + 1
            self._schemas.append(Schema(id=self._kf_id, name=KF_SCHEMA, encoding="ros2msg",
                                        data=keyframes.schema_text))
            self._channels.append(Channel(id=self._kf_id, topic=KF_TOPIC, message_encoding="cdr",
                                          schema_id=self._kf_id, metadata={}))
        self._file = open(self._part, "wb")
        try:
            rb = RecordBuilder()
            Header(profile=PROFILE, library="frictionrt").write(rb)
            for r in (*self._schemas, *self._channels):
                r.write(rb)
            self._file.write(MAGIC + rb.end())
            self.add_metadata("frictionrt", dict(metadata))
            self.add_metadata("signals", signals_record(self.signals, self.rate_hz, self.start_ns))
            if keyframes is not None:
                self.add_metadata(KF_RECORD, keyframes.record())
        except BaseException:
            self._file.close()
            raise

    def add_metadata(self, name: str, record: dict[str, str]) -> None:
        """Write a metadata record (indexed in the summary)."""
        rb = RecordBuilder()
        Metadata(name=name, metadata=record).write(rb)
        data = rb.end()
        self._metadata_indexes.append(MetadataIndex(offset=self._file.tell(), length=len(data), name=name))
        self._file.write(data)

    def add_attachment(self, name: str, media_type: str, data: bytes) -> None:
        """Write an attachment record (indexed in the summary); times 0: it belongs to no tick."""
        rb = RecordBuilder()
        Attachment(create_time=0, log_time=0, name=name, media_type=media_type, data=data).write(rb)
        rec = rb.end()
        self._attachment_indexes.append(AttachmentIndex(offset=self._file.tell(), length=len(rec), log_time=0,
                                                        create_time=0, data_size=len(data), name=name,
                                                        media_type=media_type))
        self._file.write(rec)

    def write_keyframes(self, f: np.ndarray, i: np.ndarray) -> None:
        """Key frames (``frictionrt.rt.log.keyframes``: float64 rows f, int64 rows i with the tick first)
        of ticks not yet written, given before the block that holds their ticks; each goes into
        that tick's chunk before the tick's messages. Ignored without a key-frame layout."""
        if self.keyframes is None or len(i) == 0:
            return
        msgs = self.keyframes.encode(f, i, stamps_ns(i[:, 0], self.rate_hz, self.start_ns))
        self._kf_pending.extend(zip(i[:, 0].tolist(), msgs))

    def write_block(self, k0: int, block: np.ndarray) -> None:
        """Append ticks k0 .. k0 + n - 1; block is float64 (n, n_sig), row i = tick k0 + i.
        Ticks must increase from block to block; a gap (a dropped block) is allowed."""
        if self._closed:
            raise ValueError(f"{self.path}: write_block after close")
        k0, n = check_block(self.path, k0, block, len(self.signals), self._k_next)
        i = 0
        while i < n:
            m = min(n - i, self.chunk_ticks - self._fill)
            self._encode(k0 + i, block[i:i + m])
            i += m
            if self._fill == self.chunk_ticks:
                self._write_chunk()
        self._k_next = k0 + n

    def _encode(self, k0: int, rows: np.ndarray) -> None:
        """Copy ticks k0.. (rows) into the open chunk's records."""
        m = rows.shape[0]
        a, b = self._fill, self._fill + m
        k, t, msgs = encode_block(self.path, self.topics, k0, rows, self.rate_hz, self.start_ns)
        t = t.astype("<u8").view(np.uint8).reshape(m, 8)
        seq = (k & 0xFFFFFFFF).astype("<u4").view(np.uint8).reshape(m, 4)
        buf = self._buf
        for tp, o, msg in zip(self.topics, self._rec_off, msgs):
            buf[a:b, o + 11:o + 15] = seq
            buf[a:b, o + 15:o + 23] = t
            buf[a:b, o + 23:o + 31] = t
            buf[a:b, o + _MSG_HEAD:o + _MSG_HEAD + tp.message_size] = msg
        self._buf_k[a:b] = k
        self._fill = b

    def _write_chunk(self) -> None:
        """Compress the open chunk, write it and its message indexes."""
        n = self._fill
        if n == 0:
            return
        kf_rows, kf_msgs = self._chunk_keyframes(n)
        kf_len = _MSG_HEAD + (self.keyframes.message_size if self.keyframes is not None else 0)
        if kf_rows:   # each key frame's record before its tick's messages
            pieces, a = [], 0
            for r, msg in zip(kf_rows, kf_msgs):
                pieces += [self._buf[a:r].tobytes(), msg]
                a = r
            data = b"".join(pieces + [self._buf[a:n].tobytes()])
        else:
            data = self._buf[:n].tobytes()
        comp = self._zstd.compress(data)
        times = stamps_ns(self._buf_k[:n], self.rate_hz, self.start_ns)
        t0, t1 = int(times[0]), int(times[-1])
        start = self._file.tell()
        body = struct.pack("<QQQI", t0, t1, len(data), zlib.crc32(data)) + struct.pack("<I", 4) + b"zstd" + \
            struct.pack("<Q", len(comp))
        self._file.write(struct.pack("<BQ", Opcode.CHUNK, len(body) + len(comp)) + body)
        self._file.write(comp)
        chunk_len = 9 + len(body) + len(comp)
        # message indexes: per channel (log time, offset of the record in the chunk's records)
        idx_start = self._file.tell()
        offsets, pos = {}, idx_start
        entries = np.empty((n, 2), "<u8")
        entries[:, 0] = times
        before = np.searchsorted(np.array(kf_rows, np.int64), np.arange(n), side="right")   # key frames at rows <= i
        rows_off = np.arange(n, dtype=np.uint64) * np.uint64(self.row_bytes) + before.astype(np.uint64) * np.uint64(kf_len)
        for ch, o in enumerate(self._rec_off, start=1):
            entries[:, 1] = rows_off + np.uint64(o)
            rec = struct.pack("<BQHI", Opcode.MESSAGE_INDEX, 2 + 4 + 16 * n, ch, 16 * n) + entries.tobytes()
            self._file.write(rec)
            offsets[ch] = pos
            pos += len(rec)
        if kf_rows:
            m = len(kf_rows)
            kf_entries = np.empty((m, 2), "<u8")
            kf_entries[:, 0] = times[kf_rows]
            kf_entries[:, 1] = np.array(kf_rows, np.uint64) * np.uint64(self.row_bytes) + \
                np.arange(m, dtype=np.uint64) * np.uint64(kf_len)
            rec = struct.pack("<BQHI", Opcode.MESSAGE_INDEX, 2 + 4 + 16 * m, self._kf_id, 16 * m) + kf_entries.tobytes()
            self._file.write(rec)
            offsets[self._kf_id] = pos
            pos += len(rec)
            self._n_kf += m
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=t0, message_end_time=t1, chunk_start_offset=start, chunk_length=chunk_len,
            message_index_offsets=offsets, message_index_length=pos - idx_start, compression="zstd",
            compressed_size=len(comp), uncompressed_size=len(data)))
        if self._n_ticks == 0:
            self._t_first = t0
        self._t_last = t1
        self._n_ticks += n
        self._fill = 0

    def _chunk_keyframes(self, n: int) -> tuple[list[int], list[bytes]]:
        """(rows, records) of the pending key frames whose ticks are in the open chunk's n rows;
        those of ticks the chunk does not hold (a dropped block's) are dropped."""
        if not self._kf_pending:
            return [], []
        ks = self._buf_k[:n]
        rows, recs, keep = [], [], []
        for k, msg in self._kf_pending:
            if k > ks[-1]:
                keep.append((k, msg))
                continue
            r = int(np.searchsorted(ks, k))
            if r < n and ks[r] == k:
                t = int(stamps_ns(np.array([k]), self.rate_hz, self.start_ns)[0])
                head = struct.pack("<BQHIQQ", Opcode.MESSAGE, _MSG_HEAD - 9 + len(msg), self._kf_id,
                                   k & 0xFFFFFFFF, t, t)
                rows.append(r)
                recs.append(head + msg.tobytes())
        self._kf_pending = keep
        order = sorted(range(len(rows)), key=rows.__getitem__)
        return [rows[j] for j in order], [recs[j] for j in order]

    def _finish(self) -> None:
        """The open chunk, data end, summary (schemas, channels, statistics, chunk and metadata
        indexes, summary offsets), footer, magic: as mcap's Writer.finish."""
        self._write_chunk()
        rb = RecordBuilder()
        DataEnd(0).write(rb)
        self._file.write(rb.end())
        summary_start = self._file.tell()
        sb = RecordBuilder()
        groups = []

        def group(opcode, records):
            g0 = sb.count
            for r in records:
                r.write(sb)
            groups.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + g0,
                                        group_length=sb.count - g0))
        n_top = len(self.topics)
        n_ch = len(self._channels)
        counts = {c.id: self._n_ticks for c in self._channels[:n_top]}
        if self.keyframes is not None:
            counts[self._kf_id] = self._n_kf
        stats = Statistics(message_count=self._n_ticks * n_top + self._n_kf, schema_count=n_ch, channel_count=n_ch,
                           attachment_count=len(self._attachment_indexes), metadata_count=len(self._metadata_indexes),
                           chunk_count=len(self._chunk_indexes), message_start_time=self._t_first,
                           message_end_time=self._t_last,
                           channel_message_counts=counts)
        group(Opcode.SCHEMA, self._schemas)
        group(Opcode.CHANNEL, self._channels)
        group(Opcode.STATISTICS, [stats])
        group(Opcode.CHUNK_INDEX, self._chunk_indexes)
        if self._attachment_indexes:
            group(Opcode.ATTACHMENT_INDEX, self._attachment_indexes)
        group(Opcode.METADATA_INDEX, self._metadata_indexes)
        offsets_start = summary_start + sb.count
        for g in groups:
            g.write(sb)
        summary = sb.end()
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 8 + 8 + 4, summary_start, offsets_start), crc)
        self._file.write(summary)
        fb = RecordBuilder()
        Footer(summary_start=summary_start, summary_offset_start=offsets_start, summary_crc=crc).write(fb)
        self._file.write(fb.end() + MAGIC)

    def close(self) -> None:
        """Finish the file and rename it onto ``path``. Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            self._finish()
        finally:
            self._file.close()
        os.replace(self._part, self.path)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self.close()


class Batched:
    """A sink that passes contiguous blocks on to ``sink`` in batches of >= ``ticks`` rows (and
    the rest at a gap or on close)."""

    def __init__(self, sink, ticks: int):
        self.sink, self.ticks = sink, ticks
        self._parts: list[np.ndarray] = []
        self._k0 = self._n = 0

    def write_block(self, k0: int, block: np.ndarray) -> None:
        if self._parts and k0 != self._k0 + self._n:
            self._flush()
        if not self._parts:
            self._k0 = k0
        self._parts.append(block)
        self._n += len(block)
        if self._n >= self.ticks:
            self._flush()

    def _flush(self) -> None:
        if self._parts:
            block = self._parts[0] if len(self._parts) == 1 else np.concatenate(self._parts)
            self._parts, self._n = [], 0
            self.sink.write_block(self._k0, block)

    def close(self) -> None:
        try:
            self._flush()
        finally:
            self.sink.close()


class LogWriter:
    """The writer thread of one run (module docstring).

    Parameters
    ----------
    sinks : objects with ``write_block(k0, block)`` and ``close()`` (closed by ``finish()``,
        in this order).
    block_ticks : rows per block.
    ring_s : the ring's span [s of simulated time], rounded to whole blocks (at least one):
        ``ring_ticks`` rows, the log ``run`` allocates. None: no ring (the log holds the whole
        run and nothing is ever dropped).
    rate_hz : tick rate [Hz] (to convert ring_s to ticks).
    mcap : the McapBlockWriter among the sinks, if any: receives the closing metadata record
        ``frictionrt.writer`` (dropped blocks, block and ring size, ticks written, ticks left
        unwritten after a Ctrl-C).

    ``frictionrt.rt.loop.driver.run(..., writer=w)`` calls ``w.start(log, clk, k0, paced, digest, ticks)`` before the loop and
    ``w.finish()`` after it in every case; ``finish()`` is idempotent and also closes the sinks
    of a writer that never started.
    """

    def __init__(self, sinks, *, block_ticks: int = BLOCK_TICKS, ring_s: float | None = RING_S,
                 rate_hz: float = 21000.0, mcap: McapBlockWriter | None = None):
        if block_ticks < 1:
            raise ValueError(f"block_ticks {block_ticks}: must be >= 1")
        if ring_s is not None and not ring_s > 0:
            raise ValueError(f"ring {ring_s} s: must be > 0")
        self.sinks = list(sinks)
        self.block_ticks = int(block_ticks)
        self.ring_ticks = None if ring_s is None else \
            self.block_ticks * max(1, round(ring_s * rate_hz / self.block_ticks))
        self.mcap = mcap
        self.dropped_blocks = 0
        self.written_ticks = 0
        self.unwritten_ticks = 0   # rows the loop completed that a Ctrl-C left unwritten
        self.interrupted = False   # a Ctrl-C reached finish() or cut the writing short (module docstring)
        self.error: BaseException | None = None
        self._done = threading.Event()
        self._ended = threading.Event()   # the thread's files are closed (not Thread.join: finish())
        self._abort = threading.Event()
        self._thread: threading.Thread | None = None
        self._closed = False

    def start(self, log: np.ndarray, clk: np.ndarray, k0: int, paced: bool, digest=None,
              ticks: int | None = None, keyframes=None) -> None:
        """Start draining ``log`` (tick k0 + i in row i mod len(log); ticks below k0 +
        clk[CLK_TICKS] complete); each block taken out is also folded into ``digest``
        (``frictionrt.rt.loop.digest.RunDigest``) if given. ``ticks``: the run's length, if known; a loop
        whose count has reached it has ended (paced: it overwrites no more rows), before
        ``finish()`` says so. ``keyframes``: (interval, float64 ring, int64 ring) of the loop's key
        frames (``frictionrt.rt.loop.keyframe``; tick k's in row (k / interval) mod len), taken out with
        the block that holds their tick and handed to the sinks' ``write_keyframes`` first."""
        self._log, self._clk, self._k0 = log, clk, int(k0)
        self._kf = keyframes if keyframes is not None and keyframes[0] > 0 else None
        self.keyframes_written = 0
        self._paced = paced
        self._digest = digest
        self._ticks = ticks
        self._next = 0   # next row to write (or drop)
        self._thread = threading.Thread(target=self._main, name="frictionrt-writer", daemon=False)
        self._thread.start()

    def finish(self) -> None:
        """The loop is done: write the complete rows not yet written (paced: within the ring),
        close the sinks, wait for the thread. After a Ctrl-C (the loop's stop flag, or one during
        this call, which it absorbs) at most ``INTERRUPT_DRAIN_S`` more of writing. Errors are
        kept in ``error``."""
        from frictionrt.rt.common.clock import CLK_STOP
        if self._thread is None:
            self._close()
            return
        self._done.set()
        deadline = time.monotonic() + INTERRUPT_DRAIN_S if self._clk[CLK_STOP] else None
        while not self._ended.is_set():   # not join: one cut short by Ctrl-C can end early (cpython#90882)
            try:
                self._ended.wait(POLL_S)
            except KeyboardInterrupt:
                self.interrupted = True
                if deadline is None:
                    deadline = time.monotonic() + INTERRUPT_DRAIN_S
            if deadline is not None and time.monotonic() >= deadline:
                self._abort.set()
        try:
            self._thread.join()   # ended: it only returns
        except KeyboardInterrupt:
            self.interrupted = True
        self.interrupted |= self._abort.is_set()

    # --- the thread ------------------------------------------------------------------------
    def _main(self) -> None:
        from frictionrt.rt.common.clock import CLK_TICKS
        try:
            if self._paced and WRITER_NICE:  # on a shared core the scheduler prefers the loop
                os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), WRITER_NICE)
            while True:
                final = self._done.is_set()   # read before the counter: the rows below it are final
                while self._step(int(self._clk[CLK_TICKS]), final):
                    pass
                if final:
                    self.unwritten_ticks = int(self._clk[CLK_TICKS]) - self._next
                    break
                self._done.wait(POLL_S)
        except BaseException as exc:  # kept for the caller; the loop is never disturbed
            self.error = exc
        finally:
            from frictionrt.rt.common.clock import CLK_WRITTEN, NO_WAIT
            self._clk[CLK_WRITTEN] = NO_WAIT   # an offline loop must not wait for a writer that stopped
            try:
                self._close()
            finally:
                self._ended.set()

    def _step(self, done: int, final: bool) -> bool:
        """Drop the blocks the loop has overwritten (paced), then take one block out of the
        ring, fold it into the digest and write it, if there is one (none once aborted)."""
        from frictionrt.rt.common.clock import CLK_TICKS, CLK_WRITTEN
        if self._abort.is_set():
            return False
        ring = len(self._log)
        while self._paced and self._overwritten(done, final):
            self._next += self.block_ticks
            self.dropped_blocks += 1
        n = min(self.block_ticks, done - self._next)
        if n <= 0 or (n < self.block_ticks and not final):
            return False
        block = self._log[(self._next + np.arange(n)) % ring]   # a copy: the loop may overwrite the ring
        kf = self._take_keyframes(self._k0 + self._next, n)
        if self._paced and self._overwritten(int(self._clk[CLK_TICKS]), final):  # overwritten while copied
            self._next += self.block_ticks
            self.dropped_blocks += 1
            return True
        k0 = self._k0 + self._next
        self._clk[CLK_WRITTEN] = k0 + n   # offline, the loop may overwrite these rows now
        if self._digest is not None:
            self._digest.add(k0, block)
        for s in self.sinks:
            if kf is not None and hasattr(s, "write_keyframes"):
                s.write_keyframes(*kf)
            s.write_block(k0, block)
        if kf is not None:
            self.keyframes_written += len(kf[1])
        self._next += n
        self.written_ticks += n
        return True

    def _take_keyframes(self, k0: int, n: int):
        """(float64 rows, int64 rows) copied from the key-frame ring for the ticks k0 .. k0 + n - 1
        (a row whose tick is not the expected one is left out), or None."""
        if self._kf is None:
            return None
        interval, kf_f, kf_i = self._kf
        ks = np.arange(-(-k0 // interval) * interval, k0 + n, interval, dtype=np.int64)
        if len(ks) == 0:
            return None
        rows = (ks // interval) % len(kf_f)
        f, i = kf_f[rows], kf_i[rows]   # copies
        ok = i[:, 0] == ks
        return (f[ok], i[ok]) if ok.any() else None

    def _overwritten(self, done: int, final: bool) -> bool:
        """Whether the loop, ``done`` ticks complete, may have overwritten the row of tick
        ``_next`` (paced). Row i is overwritten once the loop has begun tick i + ring: a running
        loop may be in tick ``done``; an ended one is not, and has ended when ``finish()`` said so
        (``final``) or its count has reached the run's length (it then begins no tick, whether
        finish() has come yet or not: without this, a run no longer than the ring lost its first
        block to a look between the loop's end and finish())."""
        ended = final or (self._ticks is not None and done >= self._ticks)
        return done - self._next >= len(self._log) + (1 if ended else 0)

    def _close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self.mcap is not None:
            try:
                self.mcap.add_metadata("frictionrt.writer", {
                    "dropped_blocks": str(self.dropped_blocks), "block_ticks": str(self.block_ticks),
                    "ring_ticks": str(self.ring_ticks), "written_ticks": str(self.written_ticks),
                    "unwritten_ticks": str(self.unwritten_ticks),
                    "keyframes_written": str(getattr(self, "keyframes_written", 0)),
                    "error": "" if self.error is None else repr(self.error)})
            except BaseException as exc:
                self.error = self.error or exc
        for s in self.sinks:
            try:
                s.close()
            except BaseException as exc:
                self.error = self.error or exc


def open_run_log(base: str | os.PathLike, signals, rate_hz: float, metadata: dict[str, str], *,
                 rrd: bool = True, block_ticks: int = BLOCK_TICKS, ring_s: float | None = RING_S,
                 keyframes: KeyframeCodec | None = None) -> LogWriter:
    """A LogWriter on BASE.mcap (and BASE.rrd unless rrd is False) with ``metadata`` and, with
    ``keyframes``, the key-frame channel; the Foxglove layout of the log is written to
    BASE.foxglove.json (``frictionrt.rt.log.views``)."""
    from frictionrt.rt.log.rrd_log import RrdLogWriter
    from frictionrt.rt.log.views import write_foxglove_layout
    base = Path(base)
    mcap = McapBlockWriter(base.with_name(base.name + ".mcap"), signals, rate_hz, metadata, keyframes)
    try:
        layout = write_foxglove_layout(base.with_name(base.name + ".foxglove.json"), mcap.signals)
    except BaseException:
        mcap.close()
        raise
    sinks = [mcap]
    if rrd:
        try:
            sinks.append(Batched(RrdLogWriter(base.with_name(base.name + ".rrd"), signals, rate_hz,
                                              metadata=metadata), RRD_BATCH_TICKS))
        except BaseException:
            mcap.close()
            raise
    w = LogWriter(sinks, block_ticks=block_ticks, ring_s=ring_s, rate_hz=rate_hz, mcap=mcap)
    w.paths = {"mcap": str(mcap.path), "rrd": str(base.with_name(base.name + ".rrd")) if rrd else None,
               "foxglove": str(layout)}
    return w


def package_versions() -> dict[str, str]:
    """Versions of Python and the packages a run depends on ("" if one is not installed)."""
    out = {"python": sys.version.split()[0]}
    for p in VERSION_PACKAGES:
        try:
            out[p] = version(p)
        except PackageNotFoundError:
            out[p] = ""
    return out


def run_metadata(cfg, law: str, estimator: str, seed: int, freq_hz: float, amp_n: float, duration_s: float,
                 paced: bool, argv: list[str] | None = None, start_tick: int = 0) -> dict[str, str]:
    """The "frictionrt" metadata record of a run (all strings; floats as repr, exact)."""
    from frictionrt.rt.common.blas import state as blas_state
    from frictionrt.rt.common.codegen import compiled_target
    from frictionrt.rt.common.config import dumps
    from frictionrt.rt.common.jit_cache import source_hash
    from frictionrt.rt.common.kernel_version import KERNEL_VERSION
    return {"config": dumps(cfg), "versions": json.dumps(package_versions()),
            "codegen": json.dumps(compiled_target()), "blas": json.dumps(blas_state()), "kernels": source_hash(),
            "kernel_version": str(KERNEL_VERSION),
            "seed": str(seed), "law": law,
            "estimator": estimator, "freq_hz": repr(float(freq_hz)), "amp_n": repr(float(amp_n)),
            "duration_s": repr(float(duration_s)), "paced": str(bool(paced)).lower(),
            "start_tick": str(int(start_tick)),
            "start_utc": utc_now(),
            "command": json.dumps(list(sys.argv if argv is None else argv))}
