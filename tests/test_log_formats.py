"""Logs as the field's tools read them: every kind of log the project writes decodes with the
official ROS 2 decoder (mcap_ros2), a file written with mcap_ros2's writer is read by validate,
replay and diagnose, and logs of the previous format (version 0) are still read."""
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from rt.cli import main
from rt.data_format import validate
from rt.mcap_log import FORMAT_VERSION, read_mcap, tick_time_ns, topics_of
from rt.registry import field_names

FIXTURE_V0 = Path(__file__).parent / "fixtures" / "log_v0.mcap"
"""420 ticks of `frictionrt simulate --law lyapunov --freq 196 --amp 5 --duration 0.02 --seed 1
--no-rrd`, written by the code before the log format had a version (commit bc31228)."""


def cli(capsys, *args):
    code = main([*map(str, args)])
    out = capsys.readouterr()
    return code, out.out, out.err


def ros2_decode(path) -> dict[str, tuple[np.ndarray, np.ndarray, dict[str, list]]]:
    """Per topic: (log times [ns], stamps [ns], {field: values}) of every message, decoded with
    mcap_ros2's DecoderFactory; also checks the header profile."""
    out: dict[str, tuple[list, list, dict]] = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for _, channel, message, ros in reader.iter_decoded_messages(log_time_order=False):
            times, stamps, fields = out.setdefault(channel.topic, ([], [], {}))
            times.append(message.log_time)
            assert message.publish_time == message.log_time
            stamps.append(ros.stamp.sec * 10**9 + ros.stamp.nanosec)
            for name in ros.__slots__:
                if name != "stamp":
                    fields.setdefault(name, []).append(getattr(ros, name))
    return {t: (np.array(a, np.int64), np.array(b, np.int64), f) for t, (a, b, f) in out.items()}


def check_ros2_decode(path) -> int:
    """Every field of every message as mcap_ros2 decodes it equals what read_mcap reads (float64
    bit for bit), stamps = log times = start + (tick 10^9) // rate; returns the message count."""
    rec = read_mcap(path)
    assert rec.version == FORMAT_VERSION
    decoded = ros2_decode(path)
    assert sorted(decoded) == sorted(rec.topics)
    fields = field_names(rec.signals)
    n = 0
    for tp in topics_of(rec.signals):
        if tp.name not in decoded:
            continue
        times, stamps, values = decoded[tp.name]
        k = np.array(values.pop("tick"))
        rows = np.searchsorted(rec.k, k)
        np.testing.assert_array_equal(rec.k[rows], k)
        np.testing.assert_array_equal(times, rec.start_ns + tick_time_ns(k, rec.rate_hz))
        np.testing.assert_array_equal(stamps, times)
        assert list(values) == [fields[c] for c in tp.columns]
        for c in tp.columns:
            v = np.array(values[fields[c]], dtype=np.float64)
            np.testing.assert_array_equal(v.view(np.uint64), rec.log[rows, c].view(np.uint64))
        n += len(k)
    return n


@pytest.fixture(scope="module")
def run_log(tmp_path_factory):
    """A 0.05 s simulate run (MCAP, .rrd and layout)."""
    d = tmp_path_factory.mktemp("run")
    assert main(["simulate", "--law", "hysteresis", "--freq", "196", "--amp", "5", "--duration", "0.05",
                 "--out", str(d / "run")]) == 0
    return d / "run.mcap"


def test_simulate_logs_decode_with_the_ros2_decoder(run_log, capsys):
    capsys.readouterr()
    rec = read_mcap(run_log)
    assert check_ros2_decode(run_log) == 6 * 1050
    assert abs(rec.start_ns / 1e9 - __import__("time").time()) < 3600   # a real date, not 1970


def test_rig_campaign_and_recovered_logs_decode_with_the_ros2_decoder(tmp_path, capsys, run_log):
    from rt.config import load
    from rt.rig import make_campaign
    files = make_campaign(tmp_path / "camp", record_s=0.01, levels_n=(100.0,), ramps_s=(3e-3,), cfg=load())
    assert files and all(check_ros2_decode(f) > 0 for f in files)
    code, _, err = cli(capsys, "recover", run_log, "-o", tmp_path / "rec.mcap")
    assert code == 0, err
    assert check_ros2_decode(tmp_path / "rec.mcap") == 6 * 1050


def test_the_previous_format_is_still_read(tmp_path, capsys):
    rec = read_mcap(FIXTURE_V0)
    assert rec.version == 0 and rec.start_ns == 0 and len(rec.k) == 420
    assert rec.topics == ("/rt", "/sensors", "/observer", "/tracking", "/actuator", "/plant")
    assert rec.column("F_N1") > 0 and np.isfinite(rec.log).all()
    assert validate(FIXTURE_V0) == []
    code, out, err = cli(capsys, "replay", FIXTURE_V0, "--json")
    assert code == 0 and json.loads(out)["bit_exact"] is True, err
    code, out, err = cli(capsys, "inspect", FIXTURE_V0, "-o", tmp_path / "v0.rrd", "--json")
    assert code == 0 and json.loads(out)["ticks"] == 420, err
