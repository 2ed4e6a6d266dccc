"""Key frames in an MCAP log (format version 2): the loop's state at fixed tick multiples, as
messages of their own topic, so that a replay restarts after a gap (docs/data-format.md, "Key
frames"; what the parts are: ``frictionrt.rt.loop.keyframe``).

    topic      /keyframe, schema "frictionrt/msg/Keyframe" (ros2msg), message encoding cdr
    schema     "builtin_interfaces/Time stamp", "int64 tick", then per part of non-zero size
               "float64[N] NAME" or "int64[N] NAME" (fixed-size arrays: no length prefix in CDR),
               then the definition of builtin_interfaces/Time
    message    CDR little endian: header 00 01 00 00, stamp (int32 sec, uint32 nanosec), tick,
               the parts' values in order (every field 8 bytes: no padding); the stamp and the
               log time are those of the tick's other messages (``frictionrt.rt.log.mcap_log``), and in a
               chunk the key frame comes before its tick's messages
    metadata   record "keyframes": "interval_ticks" (k mod interval = 0), "parts" = JSON list of
               {name, type, size} in order (parts of size 0 are listed but have no field),
               "topic", "when" (the state at the start of the tick)

In memory a set of key frames is two arrays as the loop's ring holds them: float64 (m, F) with
the float64 parts in order, and int64 (m, 1 + I) with the tick, then the int64 parts.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

TOPIC = "/keyframe"
SCHEMA_NAME = "frictionrt/msg/Keyframe"
RECORD = "keyframes"
_SEPARATOR = "=" * 80
_TIME = "builtin_interfaces/Time"


@dataclass(frozen=True)
class KeyframeCodec:
    """The encoding of one layout of key frames: ``interval`` [ticks] and ``parts`` ({name, type,
    size} per part, in order)."""
    interval: int
    parts: tuple[tuple[str, str, int], ...]

    @classmethod
    def of(cls, interval: int, parts) -> KeyframeCodec:
        return cls(int(interval), tuple((str(p["name"]), str(p["type"]), int(p["size"])) for p in parts))

    @classmethod
    def from_record(cls, rec: dict[str, str]) -> KeyframeCodec:
        """The codec of a "keyframes" record; ValueError saying what is wrong."""
        try:
            codec = cls.of(int(rec["interval_ticks"]), json.loads(rec["parts"]))
        except (KeyError, ValueError, TypeError) as e:
            raise ValueError(f"the 'keyframes' record is unreadable ({type(e).__name__}: {e})") from None
        if codec.interval < 1 or any(t not in ("float64", "int64") or n < 0 for _, t, n in codec.parts):
            raise ValueError("the 'keyframes' record's interval or parts are invalid (interval >= 1; parts float64 "
                             "or int64 of size >= 0)")
        return codec

    def record(self) -> dict[str, str]:
        return {"interval_ticks": str(self.interval), "topic": TOPIC,
                "parts": json.dumps([{"name": n, "type": t, "size": s} for n, t, s in self.parts]),
                "when": "the loop's state at the start of tick k (before its sensors are read), k mod "
                        "interval_ticks = 0"}

    @property
    def widths(self) -> tuple[int, int]:
        """(float64 columns, int64 columns incl. the tick) of the in-memory arrays."""
        return (sum(s for _, t, s in self.parts if t == "float64"),
                1 + sum(s for _, t, s in self.parts if t == "int64"))

    @property
    def schema_text(self) -> bytes:
        body = f"{_TIME} stamp\nint64 tick\n" + "".join(f"{t}[{s}] {n}\n" for n, t, s in self.parts if s)
        return (body + f"{_SEPARATOR}\nMSG: {_TIME}\nint32 sec\nuint32 nanosec\n").encode()

    @property
    def message_size(self) -> int:
        return 4 + 16 + 8 * sum(s for _, _, s in self.parts)

    def _words(self) -> np.ndarray:
        """Per 8-byte word of a message after stamp and tick: its column in [f row | i row]."""
        nf = self.widths[0]
        idx, fo, io = [], 0, 1
        for _, t, s in self.parts:
            if t == "float64":
                idx.extend(range(fo, fo + s))
                fo += s
            else:
                idx.extend(range(nf + io, nf + io + s))
                io += s
        return np.array(idx, dtype=np.int64)

    def encode(self, f: np.ndarray, i: np.ndarray, stamps_ns: np.ndarray) -> np.ndarray:
        """(m, message_size) uint8 CDR messages of key frames f (m, F), i (m, 1 + I) (ticks in
        i[:, 0]) at stamps [ns]."""
        m = len(i)
        words = np.concatenate([np.ascontiguousarray(f, np.float64).view(np.uint64).reshape(m, -1),
                                np.ascontiguousarray(i, np.int64).view(np.uint64).reshape(m, -1)], axis=1)
        sec, nsec = np.divmod(np.asarray(stamps_ns, np.int64), 10**9)
        head = np.zeros((m, 2), np.uint64)
        head[:, 0] = (sec.astype(np.uint64) & 0xFFFFFFFF) | (nsec.astype(np.uint64) << np.uint64(32))
        head[:, 1] = i[:, 0].astype(np.int64).view(np.uint64)
        body = np.concatenate([head, words[:, self._words()]], axis=1).astype("<u8")
        out = np.empty((m, self.message_size), np.uint8)
        out[:, :4] = np.frombuffer(b"\x00\x01\x00\x00", np.uint8)
        out[:, 4:] = body.view(np.uint8).reshape(m, -1)
        return out

    def decode(self, rows: np.ndarray) -> KeyFrames:
        """Key frames of (m, message_size) uint8 messages (ValueError if not that size or CDR LE)."""
        if rows.ndim != 2 or rows.shape[1] != self.message_size or np.any(rows[:, :4] != [0, 1, 0, 0]):
            raise ValueError(f"{TOPIC} messages are not the {self.message_size}-byte little-endian CDR the "
                             "'keyframes' record describes")
        m = len(rows)
        body = np.ascontiguousarray(rows[:, 4:]).view("<u8").reshape(m, -1)
        nf, ni = self.widths
        words = np.zeros((m, nf + ni), np.uint64)
        words[:, nf] = body[:, 1]
        words[:, self._words()] = body[:, 2:]
        f = np.ascontiguousarray(words[:, :nf]).view(np.float64)
        i = np.ascontiguousarray(words[:, nf:]).view(np.int64)
        order = np.argsort(i[:, 0], kind="stable")
        return KeyFrames(self, i[order, 0].copy(), f[order], i[order])


@dataclass(frozen=True)
class KeyFrames:
    """The key frames of a log: ticks k (increasing), the float64 and int64 arrays (module
    docstring), their codec (interval, parts)."""
    codec: KeyframeCodec
    k: np.ndarray
    f: np.ndarray
    i: np.ndarray

    def part(self, name: str) -> np.ndarray:
        """(m, size) values of one part (float64 or int64)."""
        fo, io = 0, 1
        for n, t, s in self.codec.parts:
            if n == name:
                return self.f[:, fo:fo + s] if t == "float64" else self.i[:, io:io + s]
            if t == "float64":
                fo += s
            else:
                io += s
        raise KeyError(name)

    def at(self, k: int) -> int | None:
        """The row of the key frame of tick k, or None."""
        j = int(np.searchsorted(self.k, k))
        return j if j < len(self.k) and self.k[j] == k else None
