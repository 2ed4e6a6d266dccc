"""Crash safety with real runs: `simulate --out` killed with SIGKILL and then `frictionrt recover`
(every complete chunk back, bit for bit, replayable), SIGINT (finalised MCAP and .rrd, prompt
exit), and `frictionrt inspect` (a log or a measurement to .rrd with the default blueprint)."""
import json
import os
import signal
import time

import numpy as np
import pytest
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader

from frictionrt.rt.cli import main
from frictionrt.rt.common.config import load
from frictionrt.rt.loop import build_loop, run
from frictionrt.rt.log.mcap_log import CHUNK_BYTES, read_mcap, topics_of
from frictionrt.rt.log.recover import scan
from frictionrt.rt.log.writer import INTERRUPT_DRAIN_S
from tests.cli_process import start_cli, wait_for_chunks
from frictionrt.rt.cli.recover import RECOVER
from tests.test_logfiles import rrd_column
from tests.test_logging_loop import clock_columns
from tests.test_replay import _sensors_only_file

RATE, FREQ, AMP, SEED = 21000, 200.0, 5.0, 7
FULL_VIEWS = {"F_N1 setpoint vs measured", "friction hysteresis: F_t [N] up vs u_rel [um]", "damper",
              "rt", "sensors", "observer", "tracking", "actuator", "plant"}


def chunk_ticks(signals):
    """Ticks per chunk of McapBlockWriter: whole ticks in CHUNK_BYTES (1 MiB) of message records,
    each 31 B of record header (MCAP spec: opcode, length, channel, sequence, two times) + the CDR
    message (4 B header, 8 B stamp, 8 B tick, the aligned fields; 1088 for simulate's 85 signals)."""
    return CHUNK_BYTES // sum(31 + tp.message_size for tp in topics_of(signals))


def start_simulate(base):
    """simulate --duration 20 (420000 ticks: 10-20 s of wall time with both files) as a process."""
    return start_cli("simulate", "--freq", FREQ, "--amp", AMP, "--duration", 20, "--seed", SEED, "--out", base,
                     "--json")


def cli(capsys, *args):
    code = main([*map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


def chunk_records(path, n=None):
    """The first n chunk records of an MCAP file (whole, not decompressed)."""
    out = []
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, emit_chunks=True).records:
                if isinstance(rec, Chunk):
                    out.append(rec)
                    if len(out) == n:
                        break
        except McapError:  # the cut end of a .part file (EndOfFile)
            pass
    return out


def view_names(rrd):
    """Display names of the views and containers in an .rrd file's blueprint."""
    from rerun.chunk import RrdReader

    reader = RrdReader(rrd)
    (bp,) = reader.blueprints()
    names = set()
    for c in reader.stream(store=bp).to_chunks():
        rb = c.to_record_batch()
        for col in rb.schema.names:
            if col.endswith(":display_name"):
                names.update(v for row in rb.column(col).to_pylist() if row for v in row)
    return names


@pytest.fixture(scope="module")
def killed(tmp_path_factory):
    """A run killed with SIGKILL once its MCAP .part holds a few chunks."""
    d = tmp_path_factory.mktemp("killed")
    proc = start_simulate(d / "run")
    wait_for_chunks(proc, d / "run.mcap.part", 3)
    proc.kill()   # SIGKILL: no handler, no finally, no flush
    proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    assert not (d / "run.mcap").exists() and (d / "run.mcap.part").exists()
    return d / "run.mcap.part"


@pytest.fixture(scope="module")
def recovered(killed):
    fixed = killed.with_name("fixed.mcap")
    assert main(["recover", str(killed), "-o", str(fixed), "--json"]) == 0
    return fixed


def test_kill_9_then_recover_gives_every_complete_chunk_bit_exact(killed, tmp_path, capsys):
    fixed = tmp_path / "fixed.mcap"
    code, out, err = cli(capsys, "recover", killed, "-o", fixed, "--json")
    assert code == 0, err
    r = json.loads(out)
    n = r["ticks"]
    rec = read_mcap(fixed)
    # whole chunks of whole ticks, contiguous from 0
    assert r["chunks"] >= 3 and r["chunk_ticks"] == chunk_ticks(rec.signals) and n == r["chunks"] * r["chunk_ticks"]
    assert (r["first_tick"], r["last_tick"], r["missing_ticks"], r["finished"]) == (0, n - 1, 0, False)
    np.testing.assert_array_equal(rec.k, np.arange(n))
    # the configuration survived the kill: it is written at open, before any data
    meta = rec.metadata
    assert meta["seed"] == str(SEED) and float(meta["freq_hz"]) == FREQ and load_cfg(meta, tmp_path) == load()
    # same seed -> bit-identical: an in-process run of the recovered length
    ref = run(build_loop(load(), meta["law"], meta["estimator"]), FREQ, AMP, n / RATE, seed=SEED).log
    assert ref.shape == rec.log.shape
    keep = np.setdiff1d(np.arange(len(rec.signals)), clock_columns(rec.signals))
    np.testing.assert_array_equal(rec.log[:, keep].view(np.uint64), ref[:, keep].view(np.uint64))
    # finalised and indexed, with the source's metadata records and a recover record
    with open(fixed, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        names = [m.name for m in reader.iter_metadata()]
    n_kf = len(rec.keyframes.k)   # key frames every rt.keyframe_ticks, in the chunks of their ticks
    assert n_kf == r["keyframes"] == -(-n // load().rt.keyframe_ticks)
    assert summary.statistics.message_count == 6 * n + n_kf and len(summary.chunk_indexes) == r["chunks"]
    src_names = [m.name for m in scan(killed).metadata]   # all written at open, before the data
    assert src_names[:2] == ["frictionrt", "signals"] and names == [*src_names, "frictionrt.recover"]
    # the chunks are those of the killed file, byte for byte
    got, src = chunk_records(fixed), chunk_records(killed, r["chunks"])
    assert [c.data for c in got] == [c.data for c in src]


def load_cfg(meta, tmp_path):
    f = tmp_path / "cfg.toml"
    f.write_text(meta["config"])
    return load(f)


def test_the_recovered_log_replays_bit_exact(recovered, capsys):
    code, out, err = cli(capsys, "replay", recovered, "--json")
    r = json.loads(out)
    assert code == 0, err
    assert r["bit_exact"] is True and r["max_abs_diff"] == 0.0 and r["ticks"] == len(read_mcap(recovered).k)


def test_a_chunk_cut_short_is_reported_and_the_chunks_before_it_recovered(killed, recovered, tmp_path, capsys):
    c = chunk_records(killed, 3)
    data = killed.read_bytes()
    third = data.index(c[2].data)   # the third chunk's compressed bytes; cut in their middle
    cut = tmp_path / "cut.mcap.part"
    cut.write_bytes(data[:third + len(c[2].data) // 2])
    code, out, _ = cli(capsys, "recover", cut, "-o", tmp_path / "cut.mcap", "--json")
    r = json.loads(out)
    m = chunk_ticks(read_mcap(tmp_path / "cut.mcap").signals)
    assert code == 0 and r["ticks"] == 2 * m and r["last_tick"] == 2 * m - 1 and r["chunk_ticks"] == m
    assert f"chunk_ticks = {m} ticks = {1e3 * m / RATE:.1f} ms" in RECOVER   # the figure of recover --help
    assert r["lost_record"] == "chunk" and r["lost_chunk_ticks"] == [2 * m, 3 * m - 1]
    assert r["lost_bytes"] > len(c[2].data) // 2
    np.testing.assert_array_equal(read_mcap(tmp_path / "cut.mcap").log.view(np.uint64),
                                  read_mcap(recovered).log[:2 * m].view(np.uint64))


def test_recover_refuses_bad_input_with_one_line(killed, recovered, tmp_path, capsys):
    head = killed.read_bytes()[:killed.read_bytes().index(chunk_records(killed, 1)[0].data)]
    (tmp_path / "text.mcap").write_text("time,F_N1\n0,100\n")
    (tmp_path / "empty.mcap").write_bytes(b"")
    (tmp_path / "head.mcap.part").write_bytes(head)   # header, schemas, channels, metadata: no chunk yet
    cases = [(killed, recovered, str(recovered), "output exists"),
             (tmp_path / "text.mcap", tmp_path / "a.mcap", "text.mcap", "not an MCAP file"),
             (tmp_path / "empty.mcap", tmp_path / "b.mcap", "empty.mcap", "not an MCAP file"),
             (tmp_path / "head.mcap.part", tmp_path / "c.mcap", "head.mcap.part", "no complete chunk"),
             (tmp_path / "missing.mcap", tmp_path / "d.mcap", "missing.mcap", "no such file")]
    for src, dst, name, problem in cases:
        before = sorted(os.listdir(tmp_path))
        code, out, err = cli(capsys, "recover", src, "-o", dst)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, (src, err)
        assert name in err and problem in err, err
        assert sorted(os.listdir(tmp_path)) == before   # nothing written, nothing left behind


def test_sigint_leaves_a_finalised_mcap_and_a_valid_rrd_and_exits_promptly(tmp_path):
    from rerun.chunk import RrdReader

    proc = start_simulate(tmp_path / "sig")
    wait_for_chunks(proc, tmp_path / "sig.mcap.part", 3)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    t_exit = time.monotonic() - t0
    assert proc.returncode == 130, stderr
    # the writer stops INTERRUPT_DRAIN_S after the Ctrl-C; then the block in hand, closing both files
    # and the summary: measured 0.7-2.4 s (load 1-6); before, it wrote its whole backlog (9 s)
    assert t_exit < 8.0 + INTERRUPT_DRAIN_S
    s = json.loads(stdout)
    assert s["interrupted"] and 0 < s["ticks"] < 20 * RATE and s["dropped_blocks"] == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sig.foxglove.json", "sig.mcap", "sig.rrd"]   # no .part left
    n = s["ticks"] - s["unwritten_ticks"]
    rec = read_mcap(tmp_path / "sig.mcap")
    assert n >= 3 * chunk_ticks(rec.signals)
    np.testing.assert_array_equal(rec.k, np.arange(n))
    with open(tmp_path / "sig.mcap", "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        writer = {m.name: m.metadata for m in reader.iter_metadata()}["frictionrt.writer"]
    assert summary.statistics.message_count == 6 * n + len(rec.keyframes.k)   # and the key frames of its ticks
    assert len(rec.keyframes.k) == -(-n // load().rt.keyframe_ticks)
    assert len(summary.chunk_indexes) == summary.statistics.chunk_count == -(-n // chunk_ticks(rec.signals))
    assert writer["written_ticks"] == str(n) and writer["unwritten_ticks"] == str(s["unwritten_ticks"])
    # the .rrd: readable, its blueprint, the same ticks and values as the MCAP file
    assert len(RrdReader(tmp_path / "sig.rrd").blueprints()) == 1
    k, t, v = rrd_column(tmp_path / "sig.rrd", "/tracking/F_set_filtered")
    np.testing.assert_array_equal(k, np.arange(n))
    np.testing.assert_array_equal(t, k * 10**9 // RATE)
    np.testing.assert_array_equal(v, rec.log[:, rec.column("F_set_filtered")])


def test_inspect_converts_a_run_log_with_the_default_blueprint(recovered, capsys):
    from rerun.chunk import RrdReader

    rrd = recovered.with_suffix(".rrd")
    code, out, err = cli(capsys, "inspect", recovered, "--json")
    assert code == 0, err
    r = json.loads(out)
    rec = read_mcap(recovered)
    assert r["output"] == str(rrd) and r["ticks"] == len(rec.k) and len(r["topics"]) == 6
    entities = {c.entity_path for c in RrdReader(rrd).stream().to_chunks() if not c.is_static}
    assert entities == {f"/{o}" for _, _, o in rec.signals} | {"/hysteresis"}
    assert view_names(rrd) == FULL_VIEWS
    k, _, v = rrd_column(rrd, "/plant/v_rel")
    np.testing.assert_array_equal(k, rec.k)
    np.testing.assert_array_equal(v, rec.log[:, rec.column("v_rel")])
    # an existing output is refused unless --force
    mtime = rrd.stat().st_mtime_ns
    code, out, err = cli(capsys, "inspect", recovered)
    assert code == 2 and str(rrd) in err and "--force" in err and rrd.stat().st_mtime_ns == mtime
    code, _, err = cli(capsys, "inspect", recovered, "--force")
    assert code == 0 and rrd.stat().st_mtime_ns != mtime


def test_inspect_converts_a_measurement_with_a_gap(recovered, tmp_path, capsys):
    """Only /sensors, ticks 0..999 and 1500..1999 (a dropped stretch): the .rrd has the /sensors
    entities at exactly those ticks, and only the setpoint and sensors views."""
    from rerun.chunk import RrdReader

    from frictionrt.rt.log.mcap_log import McapLog
    rec = read_mcap(recovered)
    rows = np.r_[0:1000, 1500:2000]   # within the 3 chunks the kill leaves at least
    part = McapLog(rec.path, rec.signals, rec.log[rows], rec.k[rows], rec.rate_hz, rec.metadata, rec.topics)
    meas = _sensors_only_file(tmp_path / "meas.mcap", part)
    code, out, err = cli(capsys, "inspect", meas, "-o", tmp_path / "view.rrd", "--json")
    assert code == 0, err
    assert json.loads(out)["topics"] == ["/sensors"]
    entities = {c.entity_path for c in RrdReader(tmp_path / "view.rrd").stream().to_chunks() if not c.is_static}
    assert entities == {"/sensors"}
    assert view_names(tmp_path / "view.rrd") == {"F_N1 setpoint vs measured", "damper", "sensors"}
    k, _, v = rrd_column(tmp_path / "view.rrd", "/sensors/F_cell")
    np.testing.assert_array_equal(k, rows)
    np.testing.assert_array_equal(v, rec.log[rows, rec.column("F_cell")])


def test_inspect_refuses_bad_files_with_one_line(killed, tmp_path, capsys):
    (tmp_path / "text.mcap").write_text("time,F_N1\n0,100\n")
    for src, problem in [(tmp_path / "text.mcap", "not an MCAP file"), (killed, "frictionrt recover"),
                         (tmp_path / "missing.mcap", "no such file")]:
        code, out, err = cli(capsys, "inspect", src, "-o", tmp_path / "x.rrd")
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
        assert str(src) in err and problem in err, err
    code, _, err = cli(capsys, "inspect", tmp_path / "text.mcap", "-o", tmp_path / "x.png")
    assert code == 2 and ".rrd" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["text.mcap"]


def without_chunk(src, dst, i):
    """The .part file src without its chunk i (0-based) and that chunk's message indexes: a gap of
    one chunk's ticks, as a dropped block leaves one, in a file that was then killed."""
    import struct
    data = src.read_bytes()
    pos, out, chunk, skip = 8, [data[:8]], -1, False
    while pos + 9 <= len(data):
        op, n = struct.unpack_from("<BQ", data, pos)
        end = pos + 9 + n
        if end > len(data):
            break
        if op == 0x06:   # chunk
            chunk += 1
            skip = chunk == i
        elif op != 0x07:  # not a message index: the chunk's records have ended
            skip = False
        if not skip:
            out.append(data[pos:end])
        pos = end
    out.append(data[pos:])   # the cut record at the end, as the kill left it
    dst.write_bytes(b"".join(out))
    return dst


def test_a_killed_run_with_a_gap_recovers_and_replays_from_the_next_key_frame(killed, tmp_path, capsys):
    """The killed file without its second chunk (ticks m..2m-1, m = 823 ticks per chunk), then
    `recover`: the key frames survive with their chunks (0 and 2100: rt.keyframe_ticks), and
    replay compares 0..m-1 from rest and 2100.. from the key frame of 2100 bit for bit, 2m..2099
    not compared."""
    part = without_chunk(killed, tmp_path / "gap.mcap.part", 1)
    code, out, err = cli(capsys, "recover", part, "-o", tmp_path / "gap.mcap", "--json")
    r = json.loads(out)
    rec = read_mcap(tmp_path / "gap.mcap")
    m = chunk_ticks(rec.signals)
    assert code == 0 and r["missing_ticks"] == m and r["keyframes"] >= 2, err
    assert list(rec.keyframes.k[:2]) == [0, 2100] and r["last_tick"] >= 2100 > 2 * m
    code, out, err = cli(capsys, "replay", tmp_path / "gap.mcap", "--json")
    res = json.loads(out)
    assert code == 0 and res["bit_exact"] is True, err
    assert res["compared_ranges"] == [[0, m - 1], [2100, r["last_tick"]]] and res["missing_ranges"] == [[m, 2 * m - 1]]
    assert res["not_compared_ranges"] == [[2 * m, 2099]] and res["restarted_from"] == [2100]
