"""HIL-style replay (rt.loop.replay, frictionrt replay): a fresh run's log replayed through the
controller stack is bit-exact (oracle and observer), a measurement with only /sensors replays
without comparison, a changed command is found, bad files exit 2 naming the file."""
import json

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.log.mcap_log import read_mcap
from frictionrt.rt.loop.replay import COMMANDED, replay_outputs
from frictionrt.rt.log.writer import McapBlockWriter

F3, AMP = 223.6, 5.0


def simulate(path, law, estimator, duration="0.2"):
    code = main(["simulate", "--law", law, "--estimator", estimator, "--freq", str(F3), "--amp", str(AMP),
                 "--duration", duration, "--out", str(path), "--no-rrd", "--json"])
    assert code == 0
    return path.with_name(path.name + ".mcap")


def replay(capsys, *args):
    code = main(["replay", *map(str, args), "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out else None), out.err


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """Two fresh 0.2 s runs: oracle + hysteresis, observer + Lyapunov."""
    d = tmp_path_factory.mktemp("runs")
    return {"oracle": simulate(d / "oracle", "hysteresis", "oracle"),
            "observer": simulate(d / "observer", "lyapunov", "observer")}


@pytest.mark.parametrize("estimator, law", [("oracle", "hysteresis"), ("observer", "lyapunov")])
def test_replay_of_a_fresh_run_is_bit_exact(logs, capsys, estimator, law):
    code, r, _ = replay(capsys, logs[estimator])
    assert code == 0
    assert r["ticks"] == 4200 and r["bit_exact"] is True and r["max_abs_diff"] == 0.0
    assert r["signals_compared"] == list(COMMANDED)
    assert {"u_rel_hat", "v_rel_hat", "F_set", "u0", "F_set_filtered", "V_cmd", "saturated"} <= set(COMMANDED)
    assert (r["estimator"], r["law"], r["missing_ticks"]) == (estimator, law, 0)
    # not vacuous: the law really commanded something
    assert r["outputs"]["V_cmd"]["max"] > r["outputs"]["V_cmd"]["min"]


def test_a_changed_command_is_found(logs, capsys, tmp_path):
    rec = read_mcap(logs["oracle"])
    log = rec.log.copy()
    c = rec.column("F_set_filtered")
    log[1234, c] = np.nextafter(log[1234, c], np.inf)  # one ulp
    with McapBlockWriter(tmp_path / "changed.mcap", rec.signals, rec.rate_hz, rec.metadata) as w:
        w.write_block(0, log)
    code, r, _ = replay(capsys, tmp_path / "changed.mcap")
    assert code == 1 and r["bit_exact"] is False and r["first_mismatch_tick"] == 1234
    assert 0 < r["max_abs_diff"] < 1e-12
    assert [k for k, v in r["max_abs_diff_by_signal"].items() if v] == ["F_set_filtered"]


def test_measured_data_with_sensors_only_replays_without_comparison(logs, capsys, tmp_path):
    """A measurement: only /sensors (and the configuration), observer estimator. Nothing to
    compare against, but the controller's outputs are those of the run that recorded the sensors."""
    rec = read_mcap(logs["observer"])
    meas = _sensors_only_file(tmp_path / "meas.mcap", rec)
    assert read_mcap(meas).topics == ("/sensors",)
    code, r, _ = replay(capsys, meas)
    assert code == 0 and r["bit_exact"] is None and r["max_abs_diff"] is None and r["signals_compared"] == []
    assert r["ticks"] == 4200 and r["estimator"] == "observer" and r["missing_ticks"] == 0
    _, k, out = replay_outputs(meas)
    ref = rec.log[:, [rec.column(c) for c in COMMANDED]]
    np.testing.assert_array_equal(k, rec.k)
    np.testing.assert_array_equal(out.view(np.uint64), ref.view(np.uint64))


def _sensors_only_file(path, rec):
    """rec's /sensors topic and metadata alone, written with mcap's own writer (as a
    measurement converter would)."""
    from mcap.writer import CompressionType, Writer

    from frictionrt.rt.log.mcap_log import signals_record, stamps_ns, topics_of
    tp = next(t for t in topics_of(rec.signals) if t.name == "/sensors")
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start()
        ch = w.register_channel(tp.name, "cdr", w.register_schema(tp.schema_name, "ros2msg", tp.schema_text))
        w.add_metadata("frictionrt", rec.metadata)
        w.add_metadata("signals", signals_record(rec.signals, rec.rate_hz, rec.start_ns))
        t = stamps_ns(rec.k, rec.rate_hz, rec.start_ns)
        for k, tk, msg in zip(rec.k, t, tp.encode(rec.k, t, rec.log)):
            w.add_message(ch, int(tk), msg.tobytes(), int(tk), int(k))
        w.finish()
    return path


@pytest.mark.timing
def test_paced_replay_takes_real_time_and_stays_bit_exact(logs, capsys):
    code, r, _ = replay(capsys, logs["oracle"], "--paced")
    assert code == 0 and r["paced"] and r["bit_exact"] is True
    assert r["wall_s"] >= 0.19 and r["realtime_factor"] <= 1.05


@pytest.mark.parametrize("content, problem", [(None, "no such file"), (b"", "not an MCAP file"),
                                              (b"time,F_cell\n0,100\n", "not an MCAP file"),
                                              ("cut", "truncated")])
def test_bad_files_exit_2_naming_the_file(logs, capsys, tmp_path, content, problem):
    f = tmp_path / "bad.mcap"
    if content == "cut":
        f.write_bytes(logs["oracle"].read_bytes()[:-100])
    elif content is not None:
        f.write_bytes(content)
    code, out, err = replay(capsys, f)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and out == {"error": lines[0].removeprefix("frictionrt: error: "), "exit": 2}
    assert str(f) in lines[0] and problem in lines[0]
