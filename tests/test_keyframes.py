"""Key frames (rt/loop/keyframe.py, rt/log/keyframes.py): the loop's state in the log at fixed tick
multiples, and replay (numba, --c, --plant) restarting from them after a gap in the log."""
import json

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.common.config import load
from frictionrt.rt.log import mcap_log
from frictionrt.rt.log.mcap_log import read_mcap
from frictionrt.rt.log.writer import McapBlockWriter
from frictionrt.rt.loop import build_loop, run
from frictionrt.rt.loop.keyframe import keyframe_parts
from tests.test_log_formats import check_ros2_decode

INTERVAL, TICKS = 250, 1050   # key frames at 0, 250, ..., 1000 of a 0.05 s run
GAP = (300, 600)              # rows dropped: the key frames of 250 and 500 fall into the gap
SETS = {"observer": ("rt.keyframe_plant_cache=true",), "oracle": ()}   # the observer's log with the factor cache
LAW = {"observer": "lyapunov", "oracle": "hysteresis"}


def cli(capsys, *args):
    capsys.readouterr()
    code = main([*map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Per estimator a 0.05 s log with key frames every 250 ticks (Lyapunov on the observer with the
    contact solver's cache in its key frames, hysteresis on the oracle without)."""
    d = tmp_path_factory.mktemp("keyframes")
    out = {}
    for est, sets in SETS.items():
        args = ["simulate", "--law", LAW[est], "--estimator", est, "--freq", "205", "--amp", "5", "--duration", "0.05",
                "--no-rrd", "--out", str(d / est), "--json", "--set", f"rt.keyframe_ticks={INTERVAL}"]
        for s in sets:
            args += ["--set", s]
        assert main(args) == 0
        out[est] = d / f"{est}.mcap"
    return out


def drop_rows(src, dst, a, b):
    """src with rows a..b-1 dropped, as the paced writer drops a block (its key frames go with it)."""
    rec = read_mcap(src)
    kf = rec.keyframes
    with McapBlockWriter(dst, rec.signals, rec.rate_hz, dict(rec.metadata), kf.codec if kf is not None else None) as w:
        if kf is not None:
            w.write_keyframes(kf.f, kf.i)
        w.write_block(0, rec.log[:a])
        w.write_block(int(rec.k[b]), rec.log[b:])
    return dst


def test_a_key_frame_is_the_state_a_run_has_at_its_tick(logs):
    """Key frame 500 of the observer's log equals, bit for bit, every part of the state an
    in-process run of 500 ticks ends in (``Run.final``), the factor cache included; the
    file's key frames are the multiples of the interval and decode with the ROS 2 decoder."""
    rec = read_mcap(logs["observer"])
    kf = rec.keyframes
    np.testing.assert_array_equal(kf.k, np.arange(0, TICKS, INTERVAL))
    assert rec.version == mcap_log.FORMAT_VERSION == 2 and kf.codec.interval == INTERVAL
    cfg = load(None, ["rt.keyframe_plant_cache=true"])
    st = run(build_loop(cfg, "lyapunov", "observer"), 205.0, 5.0, 500 / 21000).final
    j = kf.at(500)
    parts = keyframe_parts(st, True)
    assert [n for n, _ in parts] == [n for n, _, _ in kf.codec.parts] and len(parts) == 48
    for name, a in parts:
        got = kf.part(name)[j]
        assert np.array_equal(got.view(np.uint64) if a.dtype == np.float64 else got,
                              a.view(np.uint64) if a.dtype == np.float64 else a), name
    assert check_ros2_decode(logs["observer"]) == 6 * TICKS


@pytest.mark.parametrize("est", ["observer", "oracle"])
def test_a_dropped_block_replays_bit_exact_after_the_next_key_frame(logs, tmp_path, capsys, est):
    """Rows 300..599 dropped (key frames 250 and 500 with them): replay compares 0..299 from rest
    and 750..1049 from key frame 750 bit for bit, reports 600..749 not compared; the plant's replay
    too (bit-exact with the factor cache in the key frames, and without it, from the cache's
    patterns every key frame carries, refactorised). A key frame one ulp off makes the replay differ at its
    tick: the restart does use it."""
    path = drop_rows(logs[est], tmp_path / "gap.mcap", *GAP)
    code, out, err = cli(capsys, "replay", path, "--json")
    r = json.loads(out)
    assert code == 0 and r["bit_exact"] is True, err
    assert r["compared_ranges"] == [[0, 299], [750, 1049]] and r["missing_ranges"] == [[300, 599]]
    assert r["not_compared_ranges"] == [[600, 749]] and r["restarted_from"] == [750] and r["ticks"] == 600
    code, out, err = cli(capsys, "replay", path, "--plant", "--json")
    p = json.loads(out)
    assert code == 0 and p["bit_exact"] is True and p["restarted_from"] == [750], err
    assert "after_cold_restart" not in p
    assert p["plant_cache"] == ("in the key frames" if est == "observer" else "refactorised from the key frames' patterns")
    # a key frame one ulp off: the replay after it differs
    rec = read_mcap(path)
    part = "observer_x" if est == "observer" else "oracle_x"
    rec.keyframes.part(part)[rec.keyframes.at(750), 0] = np.nextafter(rec.keyframes.part(part)[rec.keyframes.at(750), 0], 1)
    bad = tmp_path / "bad.mcap"
    with McapBlockWriter(bad, rec.signals, rec.rate_hz, dict(rec.metadata), rec.keyframes.codec) as w:
        w.write_keyframes(rec.keyframes.f, rec.keyframes.i)
        w.write_block(0, rec.log[:300])
        w.write_block(600, rec.log[300:])
    code, out, _ = cli(capsys, "replay", bad, "--json")
    r = json.loads(out)
    assert code == 1 and r["bit_exact"] is False and r["first_mismatch_tick"] >= 750


@pytest.mark.parametrize("est", ["observer", "oracle"])
def test_a_paced_replay_restarts_from_the_key_frame_as_the_offline_one(logs, tmp_path, capsys, est):
    """replay --paced of the gap log (its ticks paced to 21 kHz): the same restart at key frame 750 and
    the same bits as the offline replay, on every compared tick (its overruns, if the machine is
    busy, do not enter: the overrun flags the controller reads are the log's)."""
    path = drop_rows(logs[est], tmp_path / "gap.mcap", *GAP)
    code, out, err = cli(capsys, "replay", path, "--paced", "--json")
    r = json.loads(out)
    assert code == 0 and r["paced"] is True and r["bit_exact"] is True, err
    assert r["compared_ranges"] == [[0, 299], [750, 1049]] and r["missing_ranges"] == [[300, 599]]
    assert r["restarted_from"] == [750] and r["ticks"] == 600


def test_a_log_of_format_1_replays_as_before_and_says_why_it_cannot_restart(logs, tmp_path, capsys, monkeypatch):
    """A log written before key frames (format version 1) with the same gap: compared up to the
    gap, the rest not compared, not a mismatch, and the reason in the report and the text."""
    rec = read_mcap(logs["observer"])
    path = tmp_path / "v1.mcap"
    monkeypatch.setattr(mcap_log, "FORMAT_VERSION", 1)   # what the writer of version 1 wrote
    with McapBlockWriter(path, rec.signals, rec.rate_hz, dict(rec.metadata)) as w:
        w.write_block(0, rec.log[:GAP[0]])
        w.write_block(GAP[1], rec.log[GAP[1]:])
    monkeypatch.undo()
    assert read_mcap(path).version == 1 and read_mcap(path).keyframes is None
    code, out, err = cli(capsys, "replay", path, "--json")
    r = json.loads(out)
    assert code == 0 and r["bit_exact"] is True, err
    assert r["compared_ranges"] == [[0, 299]] and r["not_compared_ranges"] == [[600, 1049]] and r["restarted_from"] == []
    assert r["restart_note"].startswith("the log is format version 1, written before key frames (version 2)")
    code, out, _ = cli(capsys, "replay", path)
    assert code == 0 and "written before key frames" in out and "not compared: 600..1049" in out


def test_the_file_does_not_depend_on_how_the_ticks_were_split_into_blocks(logs, tmp_path):
    """The same ticks and key frames written in blocks of 1050 or of 100 and 333 (key frames handed
    over with the block that holds them, as the writer thread does): the same bytes."""
    rec = read_mcap(logs["oracle"])
    kf = rec.keyframes
    files = []
    for name, cuts in (("one", [0, TICKS]), ("many", [0, 100, 433, 766, TICKS])):
        files.append(tmp_path / f"{name}.mcap")
        with McapBlockWriter(files[-1], rec.signals, rec.rate_hz, dict(rec.metadata), kf.codec) as w:
            for a, b in zip(cuts[:-1], cuts[1:]):
                sel = (kf.k >= a) & (kf.k < b)
                w.write_keyframes(kf.f[sel], kf.i[sel])
                w.write_block(a, rec.log[a:b])
    assert files[0].read_bytes() == files[1].read_bytes()
    back = read_mcap(files[0]).keyframes
    np.testing.assert_array_equal(back.f.view(np.uint64), kf.f.view(np.uint64))
    np.testing.assert_array_equal(back.i, kf.i)
