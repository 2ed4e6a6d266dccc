"""Bad input, fuzzed (issue 8): property-based tests (hypothesis) feed generated bad inputs
through every entry point that reads user data and require a clean end.

Entry points and what is generated (docs/reliability.md, "Bad input, fuzzed"):

    --config FILE   random bytes, truncated valid TOML, every scalar field with a wrong type,
                    NaN/inf, a value below/above its range, a huge number; unknown keys; list
                    elements missing, nameless or duplicated
    --set KEY=VALUE random keys and values, every scalar field with a bad value, list elements
                    addressed wrongly
    log files       the MCAP log of a real 0.05 s run truncated, bit-flipped, overwritten in
                    part, empty; crafted MCAP files (mcap's Writer): a foreign schema, missing
                    topics, NaN samples, non-monotonic, duplicated and off-grid times, a bad
                    "signals" record, ...; each fed to replay, inspect, recover and validate

A clean end is exit code 2 with exactly one stderr line "frictionrt: error: ..." naming the input
(the file, or the --set key) and the problem; or, where the input may be valid by chance (random
bytes that are valid TOML, a bit flip in an unchecked byte), a normal run (exit 0 or 1, one JSON
object on stdout, nothing on stderr). Never a traceback, never a hang (hypothesis deadline plus a
SIGALRM watchdog), never a partly written output (the output folder is checked after each run).
    FRF files       a small CSV and a small UFF file (rt.log.frf_files) truncated, bit-flipped, overwritten
                    in part, empty, replaced by garbage, and their JSON sidecar likewise, fed to
                    diagnose (their sidecar places the excitation off the model's point, so a file
                    that survives the damage stops at that check, exit 2, instead of a 10 s fit);
                    crafted sidecars of issue 18's keys and file kinds: a quantity, excitation,
                    sensor name, sensor_beams or drive_amplitude_v (a level in volts: > 0, with
                    excitation drive_voltage only) that is not one of the allowed, a sensor of a
                    valid name off every beam (the excitation then on the model's point), each
                    as CSV and UFF

The runs are deterministic (``derandomize=True``). HYPOTHESIS_PROFILE=long multiplies the example
counts by FRICTIONRT_FUZZ_SCALE (default 20) and draws new random examples on every run.
"""
from __future__ import annotations

import collections
import dataclasses
import datetime
import importlib
import json
import math
import os
import re
import shutil
import signal
import time
from contextlib import contextmanager
from pathlib import Path
from typing import get_type_hints

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap.writer import Writer

from frictionrt.rt.cli import main
from frictionrt.rt.common.config import LAWS, Config, dumps, load, to_dict
from frictionrt.rt.log.mcap_log import read_mcap, signals_record, stamps_ns, topics_of

# --- settings ---------------------------------------------------------------------------------

LONG = os.environ.get("HYPOTHESIS_PROFILE") == "long"
SCALE = int(os.environ.get("FRICTIONRT_FUZZ_SCALE", "20")) if LONG else 1
EXAMPLES = {"config_bytes": 150, "config_truncated": 150, "config_field": 400, "config_structure": 36,
            "set_random": 250, "set_field": 300, "set_list": 100,
            "file_mutated": 200, "file_crafted": 100, "frf_mutated": 120, "frf_crafted": 80}
FAST_S, SLOW_S = 10.0, 40.0   # per-example deadline [s]: config/--set, files (a readable log
#                               rebuilds the controller for replay: 3-5 s on the shared 2 cores)
COUNT: collections.Counter = collections.Counter()   # examples run per entry point
SECONDS: dict[str, list[float]] = collections.defaultdict(list)   # run time per file command [s]
OUTCOME: collections.Counter = collections.Counter()   # (file command, exit code)


def fuzz(name: str, deadline_s: float):
    """hypothesis settings of one fuzz test: EXAMPLES[name] * SCALE examples, fixed seed unless long."""
    return settings(max_examples=EXAMPLES[name] * SCALE, deadline=datetime.timedelta(seconds=deadline_s),
                    derandomize=not LONG, database=None, print_blob=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                           HealthCheck.data_too_large])


class Hang(BaseException):
    """Raised by the watchdog in the main thread: the command did not return in time."""


@contextmanager
def watchdog(seconds: float):
    def on_alarm(signum, frame):
        raise Hang(f"no answer within {seconds:g} s")
    old = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def run_cli(capfd, argv: list[str], seconds: float) -> tuple[int, str, str, bool]:
    """frictionrt in-process: (exit code, stdout, stderr, exited through argparse)."""
    capfd.readouterr()
    with watchdog(2 * seconds):
        try:
            rc, by_argparse = main(argv), False
        except SystemExit as exc:  # argparse: malformed options
            rc, by_argparse = exc.code, True
    out, err = capfd.readouterr()
    return rc, out, err, by_argparse


def check_end(res, allowed: tuple[int, ...], names: tuple[str, ...] = ()) -> str:
    """A clean end: rc in ``allowed``; exit 2 with one stderr line naming every string of ``names``;
    exit 0/1 with nothing on stderr. Returns the error line ('' for a normal run)."""
    rc, out, err, by_argparse = res
    assert "Traceback" not in err, err
    assert rc in allowed, (rc, out[-500:], err)
    if rc != 2:
        assert err == "", err
        return ""
    lines = err.splitlines()
    if by_argparse:   # usage lines, then "frictionrt COMMAND: error: ..."
        assert lines and ": error: " in lines[-1], err
        return lines[-1]
    assert len(lines) == 1 and lines[0].startswith("frictionrt: error: "), err
    for name in names:
        assert name in lines[0], (name, lines[0])
    return lines[0]


def listing(folder: Path) -> dict[str, int]:
    return {p.name: p.stat().st_size for p in folder.iterdir()}


# --- configuration schema ---------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Leaf:
    """One scalar field of the configuration."""
    where: tuple              # path in the TOML dict (list elements by index)
    key: str | None           # --set key (list elements by name), None if not addressable
    shown: str                # how error messages name it, e.g. plant.beams[main].E
    typ: type
    meta: dict


def leaves() -> list[Leaf]:
    out = []

    def walk(obj, where, key, shown):
        hints = get_type_hints(type(obj))
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            w, k, s = where + (f.name,), key + (f.name,), f"{shown}.{f.name}" if shown else f.name
            if dataclasses.is_dataclass(v):
                walk(v, w, k, s)
            elif isinstance(v, tuple):
                for i, item in enumerate(v):
                    name = getattr(item, "name", None)
                    walk(item, w + (i,), k + (name,), f"{s}[{i if name is None else name}]")
            else:
                out.append(Leaf(w, None if None in k else ".".join(k), s, hints[f.name], dict(f.metadata)))
    walk(Config(), (), (), "")
    return out


LEAVES = leaves()
DEFAULT = to_dict(Config())
BEAMS = {b["name"] for b in DEFAULT["plant"]["beams"]}
POINTS = {p["name"] for p in DEFAULT["plant"]["points"]}
CHOICES = {"law": set(LAWS), "excitation_point": POINTS, "frf_point": POINTS, "lower": BEAMS, "upper": {"damper"},
           "beam": BEAMS}   # str fields whose value must name something
NAMED_LISTS = ("beams", "screws", "points")
TEXT = st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00")


def wrong_types(typ) -> list:
    return {float: ["text", True, [1.0], {"a": 1.0}, datetime.date(2020, 1, 1)],
            int: [1.5, "7", True, [1], float("nan")],
            bool: [1, "true", 0.0, [True]],
            str: [1, True, 2.5, ["main"], {"a": "b"}]}[typ]


def bad_value(leaf: Leaf) -> st.SearchStrategy:
    """Values that must be refused for ``leaf``: wrong type, non-finite, out of range, huge."""
    opts = [st.sampled_from(wrong_types(leaf.typ))]
    lo, hi = leaf.meta.get("lo"), leaf.meta.get("hi")
    if leaf.typ is float:
        opts.append(st.sampled_from([math.nan, math.inf, -math.inf, 10**400, -10**400, 1e400]))
        if lo is not None:
            opts.append(st.floats(max_value=lo, exclude_max=leaf.meta["lo_inclusive"], allow_nan=False,
                                  allow_infinity=False))
        if hi is not None:
            opts.append(st.floats(min_value=hi, exclude_min=True, allow_nan=False, allow_infinity=False))
    if leaf.typ is int:
        opts.append(st.sampled_from([2**63, -2**63 - 1, 10**400]))
        if lo is not None:
            opts.append(st.integers(max_value=int(lo) - 1, min_value=-2**70))
        if hi is not None:
            opts.append(st.integers(min_value=int(hi) + 1, max_value=2**70))
    field = leaf.where[-1]
    if leaf.typ is str and field in CHOICES:
        opts.append(st.text(TEXT, max_size=20).filter(lambda s: s not in CHOICES[field]))
    return st.one_of(opts)


def toml_literal(v) -> str:
    """``v`` as the VALUE of --set KEY=VALUE (a TOML literal)."""
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {toml_literal(x)}" for k, x in v.items()) + "}"
    return tomli_w.dumps({"v": v}).split("=", 1)[1].strip()


def set_in(data: dict, where: tuple, value) -> dict:
    data = json.loads(json.dumps(data))   # deep copy of the default dict (plain JSON types)
    node = data
    for part in where[:-1]:
        node = node[part]
    node[where[-1]] = value
    return data


# --- configuration files ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def cfg_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz_cfg")


@pytest.fixture(scope="module")
def warm():
    """Import what ``simulate`` imports once, outside the per-example deadline."""
    for name in ("frictionrt.rt.loop.driver", "frictionrt.rt.log.writer", "tqdm"):
        importlib.import_module(name)


def config_run(capfd, path: Path, command: list[str]):
    return run_cli(capfd, ["--config", str(path), *command], FAST_S)


@fuzz("config_bytes", FAST_S)
@given(raw=st.binary(max_size=300))
def test_config_random_bytes(raw, cfg_dir, capfd):
    COUNT["--config"] += 1
    f = cfg_dir / "random.toml"
    f.write_bytes(raw)
    res = config_run(capfd, f, ["config", "--json"])
    check_end(res, (0, 2), names=(str(f),))
    if res[0] == 0:   # valid only if it is TOML that the configuration accepts
        load(f)


@fuzz("config_truncated", FAST_S)
@given(cut=st.integers(0, len(dumps(Config())) - 1), tail=st.sampled_from(["", "=", "[", "[[", "\"", "x", "]\n"]))
def test_config_truncated_toml(cut, tail, cfg_dir, capfd):
    COUNT["--config"] += 1
    f = cfg_dir / "truncated.toml"
    f.write_text(dumps(Config())[:cut] + tail)
    res = config_run(capfd, f, ["config", "--json"])
    check_end(res, (0, 2), names=(str(f),))
    if res[0] == 0:
        load(f)


@fuzz("config_field", FAST_S)
@given(data=st.data())
def test_config_bad_field_or_unknown_key(data, cfg_dir, capfd, warm):
    """One scalar field set to a bad value, or an unknown key in some table: refused before the
    run, nothing written to --out's folder."""
    COUNT["--config"] += 1
    out = cfg_dir / "out"
    out.mkdir(exist_ok=True)
    if data.draw(st.booleans(), label="unknown key"):
        tables = {lf.where[:-1] for lf in LEAVES} | {()}
        where = data.draw(st.sampled_from(sorted(tables, key=str)), label="table")
        allowed = set(_node(where))
        key = data.draw(st.text(TEXT, min_size=1, max_size=12).filter(lambda k: k not in allowed), label="key")
        doc = set_in(DEFAULT, where + (key,), 1.0)
        shown = key if key.isprintable() else repr(key)   # escaped: the message stays one line
    else:
        leaf = data.draw(st.sampled_from(LEAVES), label="field")
        doc = set_in(DEFAULT, leaf.where, data.draw(bad_value(leaf), label="value"))
        shown = shown_as(leaf)
    f = cfg_dir / "field.toml"
    f.write_text(tomli_w.dumps(doc))
    res = config_run(capfd, f, ["simulate", "--freq", "200", "--amp", "1", "--duration", "0.001", "--no-rrd",
                                "--json", "--out", str(out / "run")])
    check_end(res, (2,), names=(str(f), shown))
    assert listing(out) == {}


def shown_as(leaf: Leaf) -> str:
    """How a message names ``leaf`` when its value is bad: a list element whose name itself is
    bad is named by its index."""
    if leaf.where[-1] != "name":
        return leaf.shown
    return ".".join(map(str, leaf.where[:-2])) + f"[{leaf.where[-2]}].name"


def _node(where: tuple):
    node = DEFAULT
    for part in where:
        node = node[part]
    return node


@fuzz("config_structure", FAST_S)
@given(lst=st.sampled_from(NAMED_LISTS), op=st.sampled_from(["drop", "nameless", "duplicate", "empty"]),
       i=st.integers(0, 2))
def test_config_list_elements(lst, op, i, cfg_dir, capfd):
    """Named lists (beams, screws, points): an element dropped that others refer to, an element
    without a name, a duplicated name, an empty list. Screws are an exception: without the adaptive
    screw, or without any, the structure is valid (ordinary bolts only; docs/plant.md 5.3)."""
    COUNT["--config"] += 1
    items = json.loads(json.dumps(DEFAULT["plant"][lst]))
    i %= len(items)
    needed = {"beams": BEAMS, "screws": {"adaptive"}, "points": {"exc", "frf"}}[lst]
    if op == "drop":
        items = [x for x in items if x["name"] != sorted(needed)[i % len(needed)]]
    elif op == "nameless":
        del items[i]["name"]
    elif op == "duplicate":
        items.append(dict(items[i], **({"adaptive": False} if lst == "screws" else {})))
    else:
        items = []
    f = cfg_dir / "lists.toml"
    f.write_text(tomli_w.dumps({"plant": {lst: items}}))
    res = config_run(capfd, f, ["config", "--json"])
    if lst == "screws" and op not in ("nameless", "duplicate"):
        check_end(res, (0,))
        return
    check_end(res, (2,), names=(str(f), f"plant.{lst}" if op in ("nameless", "duplicate") else "plant."))


# --- --set ----------------------------------------------------------------------------------------

SET_KEYS = [lf.key for lf in LEAVES if lf.key is not None]


@fuzz("set_random", FAST_S)
@given(key=st.one_of(st.text(TEXT, max_size=30),
                     st.tuples(st.sampled_from(SET_KEYS), st.text(TEXT, max_size=8)).map(lambda t: t[0] + t[1]),
                     st.tuples(st.sampled_from(SET_KEYS), st.integers(0, 40)).map(lambda t: t[0][:t[1]])),
       value=st.text(TEXT, max_size=30), eq=st.booleans())
def test_set_random(key, value, eq, capfd):
    COUNT["--set"] += 1
    res = run_cli(capfd, [f"--set={key}={value}" if eq else f"--set={key}{value}", "config", "--json"], FAST_S)
    line = check_end(res, (0, 2))
    if line and not res[3]:
        assert "--set" in line, line


@fuzz("set_field", FAST_S)
@given(data=st.data())
def test_set_bad_field(data, capfd):
    COUNT["--set"] += 1
    leaf = data.draw(st.sampled_from([lf for lf in LEAVES if lf.key is not None]), label="field")
    text = toml_literal(data.draw(bad_value(leaf), label="value"))
    res = run_cli(capfd, [f"--set={leaf.key}={text}", "config", "--json"], FAST_S)
    check_end(res, (2,), names=(f"--set {leaf.key}=", shown_as(leaf)))


@fuzz("set_list", FAST_S)
@given(lst=st.sampled_from(NAMED_LISTS), name=st.one_of(st.sampled_from(["main", "adaptive", "exc", "0", "1"]),
                                                         st.text(TEXT, max_size=8)),
       rest=st.sampled_from(["", ".x_m", ".name", ".x_m.extra", ".F_N.0", ".nothing"]))
def test_set_list_addressing(lst, name, rest, capfd):
    """List elements are addressed by name: wrong names, a whole element, a field of a number."""
    COUNT["--set"] += 1
    key = f"plant.{lst}.{name}{rest}"
    res = run_cli(capfd, [f"--set={key}=1", "config", "--json"], FAST_S)
    line = check_end(res, (0, 2))
    if res[0] == 0:   # the only valid form: an existing element's numeric field
        element = next(x for x in DEFAULT["plant"][lst] if x["name"] == name)
        assert rest[1:] in element and rest.count(".") == 1
    else:
        assert "--set" in line, line


# --- log files ------------------------------------------------------------------------------------

COMMANDS = ("replay", "replay_plant", "inspect", "recover", "validate")
# drawn twice as often: the cheap commands (a readable file costs replay and replay --plant a
# 1.5-5 s build of plant and controller)
DRAWN = ("inspect", "recover", "validate") * 2 + ("replay", "replay_plant")


class RealLog:
    """A real run's log: its bytes, its content (McapLog) and its metadata records."""

    def __init__(self, raw: bytes, rec, records: list):
        self.raw, self.rec, self.records = raw, rec, records

    def __repr__(self) -> str:   # hypothesis prints the fixtures of a failing example
        return f"RealLog({len(self.raw)} B)"


@pytest.fixture(scope="module")
def real_log(tmp_path_factory):
    """The MCAP log of a real run (simulate --out, 0.05 s)."""
    d = tmp_path_factory.mktemp("fuzz_src")
    assert main(["simulate", "--freq", "200", "--amp", "5", "--duration", "0.05", "--out", str(d / "run"),
                 "--no-rrd", "--json"]) == 0
    path = d / "run.mcap"
    with open(path, "rb") as f:
        records = [(m.name, dict(m.metadata)) for m in make_reader(f).iter_metadata()]
    return RealLog(path.read_bytes(), read_mcap(path), records)


@pytest.fixture(scope="module")
def dirs(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz_in"), tmp_path_factory.mktemp("fuzz_out")


def file_argv(cmd: str, src: Path, out: Path) -> list[str]:
    return {"replay": ["replay", str(src), "--json"], "replay_plant": ["replay", str(src), "--plant", "--json"],
            "inspect": ["inspect", str(src), "-o", str(out / "x.rrd"), "--json"],
            "recover": ["recover", str(src), "-o", str(out / "x.mcap"), "--json"],
            "validate": ["validate", str(src), "--json"]}[cmd]


def feed(capfd, cmd: str, src: Path, out: Path, allowed: tuple[int, ...]) -> int:
    """Run ``cmd`` on ``src``: a clean end, the input untouched, the output folder holding the
    finished output after a success and nothing after a failure."""
    shutil.rmtree(out)   # empty, also after a failed example
    out.mkdir()
    before = src.read_bytes()
    t0 = time.perf_counter()
    res = run_cli(capfd, file_argv(cmd, src, out), SLOW_S)
    SECONDS[cmd].append(time.perf_counter() - t0)
    OUTCOME[cmd, res[0]] += 1
    check_end(res, allowed, names=(str(src),))
    assert src.read_bytes() == before and listing(src.parent) == {src.name: len(before)}
    produced = listing(out)
    if res[0] == 2:
        assert produced == {}, produced
    else:
        json.loads(res[1])   # one JSON object (--json)
        assert set(produced) == ({"x.rrd", "x.foxglove.json"} if cmd == "inspect" else {"x.mcap"} if cmd == "recover"
                                 else set())
    return res[0]


def normal_codes(cmd: str) -> tuple[int, ...]:
    """Exit codes of a normal run: replay 1 = a mismatch, validate 1 = problems found."""
    return (0, 2) if cmd in ("inspect", "recover") else (0, 1, 2)


@fuzz("file_mutated", SLOW_S)
@given(data=st.data(), cmd=st.sampled_from(DRAWN),
       kind=st.sampled_from(["truncate", "bitflip", "bitflip", "overwrite", "empty", "garbage"]))
def test_log_file_mutated(data, cmd, kind, real_log, dirs, capfd):
    raw = real_log.raw
    n = len(raw)
    region = st.one_of(st.integers(0, n - 1), st.integers(0, min(n, 16384) - 1), st.integers(max(0, n - 4096), n - 1))
    b = bytearray(raw)
    if kind == "truncate":
        b = b[:data.draw(region, label="cut")]
    elif kind == "bitflip":
        for _ in range(data.draw(st.integers(1, 8), label="flips")):
            b[data.draw(region, label="at")] ^= 1 << data.draw(st.integers(0, 7), label="bit")
    elif kind == "overwrite":
        at = data.draw(region, label="at")
        junk = data.draw(st.binary(min_size=1, max_size=64), label="junk")
        b[at:at + len(junk)] = junk
    elif kind == "empty":
        b = bytearray()
    else:
        b = bytearray(raw[:8] * data.draw(st.booleans(), label="magic")) + data.draw(st.binary(max_size=400))
    COUNT[f"file:{cmd}"] += 1
    src_dir, out = dirs
    shutil.rmtree(src_dir)
    src_dir.mkdir()
    src = src_dir / "run.mcap"
    src.write_bytes(bytes(b))
    # a cut or empty file fails except for recover (its purpose); flipped bits may be harmless
    strict = kind in ("truncate", "empty") and cmd != "recover"
    feed(capfd, cmd, src, out, (2,) if strict else normal_codes(cmd))


def _messages(rec, ticks: int):
    """(topic, log_time, sequence, payload) of the first ``ticks`` ticks, tick by tick."""
    out = []
    tps = topics_of(rec.signals)
    k = rec.k[:ticks]
    t = stamps_ns(k, rec.rate_hz, rec.start_ns)
    payloads = [tp.encode(k, t, rec.log[:ticks]) for tp in tps]
    for i in range(ticks):
        for tp, m in zip(tps, payloads):
            out.append((tp.name, int(t[i]), int(k[i]), m[i].tobytes()))
    return out


def write_mcap(path: Path, schemas: dict, records: list, msgs: list) -> None:
    """An MCAP file: schemas {topic: (schema name, schema encoding, text, message encoding)},
    metadata records [(name, {str: str})], messages [(topic, log_time, sequence, payload)]."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(library="fuzz")
        ids = {topic: w.register_channel(topic, menc, w.register_schema(name, enc, text))
               for topic, (name, enc, text, menc) in schemas.items()}
        for name, md in records:
            w.add_metadata(name, md)
        for topic, t, seq, data in msgs:
            w.add_message(ids[topic], t, data, t, seq)
        w.finish()


CRAFTED = ("foreign", "missing_topics", "nan", "non_monotonic", "duplicate", "off_grid", "wrong_size", "not_cdr",
           "bad_signals", "schema_mismatch", "no_messages", "huge_time", "bad_run_record")


@fuzz("file_crafted", SLOW_S)
@given(data=st.data(), cmd=st.sampled_from(DRAWN), kind=st.sampled_from(CRAFTED))
def test_log_file_crafted(data, cmd, kind, real_log, dirs, capfd):
    """Well-formed MCAP files with bad content, written with mcap's own Writer."""
    rec, records = real_log.rec, real_log.records
    ticks = data.draw(st.integers(2, 60), label="ticks")
    tps = {tp.name: tp for tp in topics_of(rec.signals)}
    schemas = {name: (tp.schema_name, "ros2msg", tp.schema_text, "cdr") for name, tp in tps.items()}
    msgs = _messages(rec, ticks)
    pick = st.integers(0, len(msgs) - 1)
    allowed = (2,)
    if kind == "foreign":   # somebody else's MCAP: JSON messages, no "signals" record
        schemas = {"/imu": ("Imu", "jsonschema", b'{"type": "object"}', "json")}
        msgs = [("/imu", t, s, json.dumps({"ax": 1.0}).encode()) for _, t, s, _ in msgs]
        records = data.draw(st.sampled_from([[], [("frictionrt", {"law": "passive"})]]), label="records")
        allowed = (1, 2) if cmd == "validate" else (2,)
    elif kind == "missing_topics":
        gone = data.draw(st.sets(st.sampled_from(sorted(tps)), min_size=1, max_size=len(tps) - 1), label="gone")
        msgs = [m for m in msgs if m[0] not in gone]
        allowed = {"replay": (0, 2), "inspect": (0,), "recover": (2,), "validate": (0, 1)}.get(cmd, (0, 1, 2))
    elif kind == "nan":
        sens = [i for i, m in enumerate(msgs) if m[0] == "/sensors"]
        for i in data.draw(st.lists(st.sampled_from(sens), min_size=1, max_size=5), label="rows"):
            topic, t, s, payload = msgs[i]
            col = data.draw(st.integers(0, (len(payload) - 20) // 8 - 1), label="col")   # after stamp and tick
            msgs[i] = (topic, t, s, payload[:20 + 8 * col] + np.float64("nan").tobytes() + payload[28 + 8 * col:])
        # replay feeds a NaN reading as a logged dropout (the supervisor then differs from the record: 1)
        # and refuses a missing v_tip_meas (2)
        allowed = {"replay": (1, 2), "inspect": (0,), "recover": (0,), "validate": (1,)}.get(cmd, (0, 1))
    elif kind == "non_monotonic":
        i, j = sorted(data.draw(st.lists(st.integers(0, ticks - 1), min_size=2, max_size=2, unique=True), label="ij"))
        per = len(tps)
        msgs[i * per:(i + 1) * per], msgs[j * per:(j + 1) * per] = msgs[j * per:(j + 1) * per], msgs[i * per:(i + 1) * per]
        allowed = (1, 2) if cmd == "validate" else (2,)
    elif kind == "duplicate":
        i = data.draw(pick, label="message")
        msgs.insert(i + 1, msgs[i])
        allowed = (1, 2) if cmd == "validate" else (2,)
    elif kind == "off_grid":
        i = data.draw(pick, label="message")
        topic, t, s, payload = msgs[i]
        msgs[i] = (topic, t + data.draw(st.sampled_from([1, 10**9, -1 if t else 3]), label="shift"), s, payload)
        allowed = (1,) if cmd == "validate" else normal_codes(cmd)   # readers take the tick field
    elif kind == "wrong_size":
        i = data.draw(pick, label="message")
        topic, t, s, payload = msgs[i]
        msgs[i] = (topic, t, s, payload[:data.draw(st.integers(0, len(payload) - 1), label="size")])
        allowed = (1, 2) if cmd == "validate" else (2,)
    elif kind == "not_cdr":
        i = data.draw(pick, label="message")
        topic, t, s, payload = msgs[i]
        msgs[i] = (topic, t, s, b"\x00\x00\x00\x00" + payload[4:])
        allowed = (1, 2) if cmd == "validate" else (2,)
    elif kind == "bad_signals":
        good = signals_record(rec.signals, rec.rate_hz)
        rows = json.loads(good["signals"])
        bad = data.draw(st.sampled_from([
            {"signals": "[not json"}, {"signals": "{}"}, {"signals": "[]"}, {"signals": "[1, 2]"}, {"signals": json.dumps(rows[1:])},
            {"signals": json.dumps([dict(r, owner="elsewhere") for r in rows])},
            {"signals": json.dumps([{k: v for k, v in r.items() if k != "unit"} for r in rows])},
            {"rate_hz": "abc"}, {"rate_hz": "0"}, {"rate_hz": "-21000"}, {"rate_hz": "nan"}, {"rate_hz": "1e400"},
            {"rate_hz": "21000.5"}, {"rate_hz": "7"}, {"rate_hz": ""}]), label="record")
        records = [(name, dict(md, **bad) if name == "signals" else md) for name, md in records]
        allowed = (1, 2) if cmd == "validate" else (2,)
    elif kind == "schema_mismatch":
        topic = data.draw(st.sampled_from(sorted(schemas)), label="topic")
        name, enc, text, menc = schemas[topic]
        schemas[topic] = data.draw(st.sampled_from([
            (name, enc, text.split(b"\n", 1)[1], menc), (name, "jsonschema", text, menc), (name, enc, text, "json"),
            ("other/msg/X", enc, text, menc), (name, enc, text.replace(b"float64", b"float32"), menc)]), label="schema")
        allowed = (1, 2) if cmd == "validate" else (2,)
    elif kind == "bad_run_record":   # the "frictionrt" record: configuration, law, estimator, seed
        bad = data.draw(st.sampled_from([
            {"config": "[rt\nrate_hz = "}, {"config": "[tracking]\nK_f = -1.0\n"}, {"config": "nonsense = 1\n"},
            {"law": "bang-bang"}, {"estimator": "psychic"}, {"seed": "abc"}, {"seed": "-1"}, {"seed": "1e400"},
            {"seed": "99999999999999999999999"}, {"faults": "nope"}, {"faults": "{}"}, {"faults": '[{"kind": "x"}]'},
            {"faults": json.dumps([{"kind": "sensor_dropout", "target": 99, "k_start": 0, "k_end": 5, "value": 0.0}])},
            {"faults": json.dumps([{"kind": "sensor_gain", "target": 0, "k_start": 9, "k_end": 2, "value": 1.0}])}]),
            label="record")
        records = [(name, dict(md, **bad) if name == "frictionrt" else md) for name, md in records]
        allowed = {"replay": (2,), "inspect": (0,), "recover": (0,)}.get(cmd, (0, 1, 2))
    elif kind == "no_messages":
        msgs = []
        allowed = {"inspect": (0,), "validate": (1,)}.get(cmd, (2,))
    else:   # huge_time: a log time beyond the last tick that int64 nanoseconds represent
        i = data.draw(pick, label="message")
        topic, _, s, payload = msgs[i]
        msgs[i] = (topic, data.draw(st.integers(2**63, 2**64 - 1), label="t"), s, payload)
        allowed = (1,) if cmd == "validate" else normal_codes(cmd)   # readers take the tick field
    COUNT[f"file:{cmd}"] += 1
    src_dir, out = dirs
    shutil.rmtree(src_dir)
    src_dir.mkdir()
    src = src_dir / "crafted.mcap"
    write_mcap(src, schemas, records, msgs)
    feed(capfd, cmd, src, out, allowed)


# --- FRF files (diagnose) -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def frf_sources(tmp_path_factory):
    """{suffix: (data bytes, sidecar bytes)} of a 40-line test of both accelerometers, CSV and UFF,
    whose sidecar places the excitation 0.1 m from the model's (a valid file stops at that check)."""
    from frictionrt.rt.log.frf_files import FORMAT, FRFTest, sidecar_path, write_frf_csv, write_frf_uff
    d = tmp_path_factory.mktemp("frf_src")
    f = 100.0 + 0.25 * np.arange(40)
    H = {s: (1.0 + 0.1j) * f / (s.startswith("a_tip") + 1.0) for s in ("a_frf_meas", "a_tip_meas")}
    meta = {"format": FORMAT, "kind": "frf", "excitation_x_m": 0.225,
            "sensor_positions_m": {"a_frf_meas": 0.45, "a_tip_meas": 0.765}, "F_N1_N": 100.0, "amplitude_n": 1.0,
            "description": "fuzz source"}
    test = FRFTest("t", f, H, np.full(40, 1.0), None, meta)
    out = {}
    for suffix, write in ((".csv", write_frf_csv), (".uff", write_frf_uff)):
        write(d / f"t{suffix}", test)
        out[suffix] = ((d / f"t{suffix}").read_bytes(), sidecar_path(d / f"t{suffix}").read_bytes())
    return out


def mutate(data, raw: bytes, kind: str) -> bytes:
    """``raw`` truncated, bit-flipped, overwritten in part, emptied or replaced by garbage."""
    n = len(raw)
    at = st.integers(0, max(0, n - 1))
    b = bytearray(raw)
    if kind == "truncate":
        b = b[:data.draw(at, label="cut")]
    elif kind == "bitflip":
        for _ in range(data.draw(st.integers(1, 8), label="flips")):
            b[data.draw(at, label="at")] ^= 1 << data.draw(st.integers(0, 7), label="bit")
    elif kind == "overwrite":
        i = data.draw(at, label="at")
        junk = data.draw(st.binary(min_size=1, max_size=64), label="junk")
        b[i:i + len(junk)] = junk
    elif kind == "empty":
        b = bytearray()
    else:
        b = bytearray(data.draw(st.binary(max_size=400), label="garbage"))
    return bytes(b)


@fuzz("frf_mutated", FAST_S)
@given(data=st.data(), suffix=st.sampled_from([".csv", ".uff"]), which=st.sampled_from(["data", "data", "sidecar"]),
       kind=st.sampled_from(["truncate", "bitflip", "bitflip", "overwrite", "empty", "garbage"]))
def test_frf_file_mutated(data, suffix, which, kind, frf_sources, dirs, capfd):
    """diagnose on a folder with one damaged FRF file or sidecar: exit 2, one line naming the
    folder (the file or sidecar in it), nothing written, the input untouched."""
    raw, side = frf_sources[suffix]
    if which == "data":
        raw = mutate(data, raw, kind)
    else:
        side = mutate(data, side, kind)
    COUNT[f"frf:{suffix}"] += 1
    src_dir, out = dirs
    shutil.rmtree(src_dir)
    src_dir.mkdir()
    (src_dir / f"t{suffix}").write_bytes(raw)
    (src_dir / "t.json").write_bytes(side)
    shutil.rmtree(out)
    out.mkdir()
    before = listing(src_dir)
    t0 = time.perf_counter()
    res = run_cli(capfd, ["diagnose", str(src_dir), "--json", "--out", str(out / "report")], FAST_S)
    SECONDS["diagnose frf"].append(time.perf_counter() - t0)
    OUTCOME["diagnose frf", res[0]] += 1
    check_end(res, (2,), names=(str(src_dir),))
    assert listing(src_dir) == before and listing(out) == {}


SENSOR_NAME = st.text(st.sampled_from("abcxyzAZ_09- .é"), min_size=0, max_size=12)


def _bad_kind(data, suffix: str) -> tuple[dict, str, str]:
    """(sidecar changes, sensor name, expected words of the error) of one crafted issue-18 case."""
    case = data.draw(st.sampled_from(["quantity", "excitation", "sensor name", "sensor_beams", "off every beam",
                                      "drive_amplitude_v"]), label="case")
    if case in ("quantity", "excitation"):
        allowed = ("accelerance", "mobility", "receptance") if case == "quantity" else ("force", "drive_voltage")
        v = data.draw(st.one_of(st.text(max_size=12).filter(lambda t: t not in allowed), st.integers(), st.none(),
                                st.lists(st.integers(), max_size=2)), label="value")
        return {case: v}, "v_tip", f"sidecar {case} is"
    if case == "sensor name":
        name = data.draw(SENSOR_NAME.filter(lambda t: not re.fullmatch(r"(?!.*__)(?!.*_\Z)[a-z][a-z0-9_]*", t)
                                            or t in ("stamp", "tick")), label="name")
        return {}, name, "not a valid sensor name"
    if case == "drive_amplitude_v":   # a level in volts: positive and finite, and only with a drive voltage
        v = data.draw(st.one_of(st.floats(max_value=0.0), st.just(float("nan")), st.just(float("inf")), st.text(max_size=4),
                                st.booleans()), label="volts")
        drive = data.draw(st.booleans(), label="drive")
        return ({"drive_amplitude_v": v} | ({"excitation": "drive_voltage", "amplitude_n": None} if drive else {}),
                "v_tip", "drive_amplitude_v")
    if case == "sensor_beams":
        v = data.draw(st.one_of(st.integers(), st.text(max_size=6), st.lists(st.text(max_size=3), max_size=2),
                                st.dictionaries(st.sampled_from(["v_tip", "v_nowhere"]), st.one_of(
                                    st.integers(), st.just(""), st.none()), min_size=1, max_size=2)), label="beams")
        return {"sensor_beams": v}, "v_tip", "sensor_beams"
    x = data.draw(st.one_of(st.floats(-100.0, -0.002), st.floats(0.777, 100.0)), label="x")
    return {"sensor_positions_m": {"v_tip": x}, "excitation_x_m": 0.325}, "v_tip", "no beam of the model holds"


@fuzz("frf_crafted", FAST_S)
@given(data=st.data(), suffix=st.sampled_from([".csv", ".uff"]))
def test_frf_sidecar_crafted(data, suffix, dirs, capfd):
    """diagnose on an FRF file whose sidecar's issue-18 keys are bad (or its sensor is off every
    beam): exit 2, one line naming the folder and the problem, nothing written."""
    from frictionrt.rt.log.frf_files import FORMAT, FRFTest, write_frf_csv, write_frf_uff
    changes, name, words = _bad_kind(data, suffix)
    COUNT[f"frf crafted:{suffix}"] += 1
    src_dir, out = dirs
    shutil.rmtree(src_dir)
    src_dir.mkdir()
    shutil.rmtree(out)
    out.mkdir()
    f = 100.0 + 0.25 * np.arange(40)
    meta = {"format": FORMAT, "kind": "frf", "excitation_x_m": 0.225, "sensor_positions_m": {name: 0.765},
            "F_N1_N": 100.0, "amplitude_n": 1.0, "description": "fuzz"}
    good = FRFTest("t", f, {"v_tip": (1.0 + 0.1j) * f}, None, None, meta | {"sensor_positions_m": {"v_tip": 0.765}})
    (write_frf_csv if suffix == ".csv" else write_frf_uff)(src_dir / f"t{suffix}", good)
    text = (src_dir / f"t{suffix}").read_text()
    if name != "v_tip":      # the crafted name in the data file and the sidecar, as a lab's tool would write it
        text = text.replace("v_tip_re", f"{name}_re").replace("v_tip_im", f"{name}_im") if suffix == ".csv" else \
            text.replace(f"{'v_tip':<80}", f"{name:<80}"[:80])
        (src_dir / f"t{suffix}").write_text(text)
    (src_dir / "t.json").write_text(json.dumps(meta | changes))
    before = listing(src_dir)
    res = run_cli(capfd, ["diagnose", str(src_dir), "--json", "--out", str(out / "report")], FAST_S)
    line = check_end(res, (2,), names=(str(src_dir),))
    assert listing(src_dir) == before and listing(out) == {}
    # a crafted name may already break the data file's own syntax (a CSV header, a UFF ID line)
    expected = (words,) + (("header column", "readable universal file", "data set", "fields") if name != "v_tip" else ())
    assert any(w in line for w in expected), line


@pytest.mark.parametrize("cmd", COMMANDS + ("config",))
@pytest.mark.parametrize("what, problem", [("folder", "not a file"), ("missing", "no such file")])
def test_input_that_is_not_a_file(cmd, what, problem, dirs, capfd):
    """A folder or a missing path where a file is expected: one line naming it."""
    src_dir, out = dirs
    src = src_dir / "folder.mcap" if what == "folder" else src_dir / "missing.mcap"
    if what == "folder":
        src.mkdir(exist_ok=True)
    argv = ["--config", str(src), "config"] if cmd == "config" else file_argv(cmd, src, out)
    line = check_end(run_cli(capfd, argv, FAST_S), (2,), names=(str(src),))
    if cmd == "config":
        problem = "Is a directory" if what == "folder" else "not found"
    assert problem in line, line


def test_total_examples():
    """At least 1000 generated bad inputs when the whole file ran (counts in docs/reliability.md)."""
    print("\nexamples", dict(COUNT), "\nfile commands (runs, total s, max s)",
          {cmd: (len(t), round(sum(t), 1), round(max(t), 2)) for cmd, t in SECONDS.items()},
          "\nfile command exit codes", dict(OUTCOME))
    if not {"--config", "--set"} <= set(COUNT) or not any(k.startswith("file:") for k in COUNT):
        pytest.skip("only part of the fuzz tests ran")
    assert sum(COUNT.values()) >= 1000, COUNT
