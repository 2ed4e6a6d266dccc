"""Logs as the field's tools read them: every kind of log the project writes decodes with the
official ROS 2 decoder (mcap_ros2), a file written with mcap_ros2's writer is read by validate,
replay and diagnose, and logs of the previous format (version 0) are still read."""
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from frictionrt.rt.cli import main
from frictionrt.rt.log.data_format import validate
from frictionrt.rt.log.keyframes import TOPIC as KF_TOPIC
from frictionrt.rt.log.mcap_log import FORMAT_VERSION, read_mcap, tick_time_ns, topics_of
from frictionrt.rt.log.registry import field_names

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
    keyframes = decoded.pop(KF_TOPIC, None)
    assert (keyframes is None) == (rec.keyframes is None)
    if keyframes is not None:
        check_keyframes_decode(rec, *keyframes)
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


def check_keyframes_decode(rec, times, stamps, values):
    """The key frames as mcap_ros2 decodes them (fixed-size arrays) equal read_mcap's, bit for
    bit, at their ticks' times."""
    kf = rec.keyframes
    k = np.array(values.pop("tick"))
    np.testing.assert_array_equal(np.sort(k), kf.k)
    np.testing.assert_array_equal(times, rec.start_ns + tick_time_ns(k, rec.rate_hz))
    np.testing.assert_array_equal(stamps, times)
    order = np.argsort(k)
    assert list(values) == [n for n, _, size in kf.codec.parts if size]
    for name, typ, _ in kf.codec.parts:
        if name in values:
            got = np.array([np.asarray(v) for v in values[name]])[order]
            ref = kf.part(name)
            np.testing.assert_array_equal(got.view(np.uint64) if typ == "float64" else got,
                                          ref.view(np.uint64) if typ == "float64" else ref)


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
    from frictionrt.rt.common.config import load
    from frictionrt.rt.discrepancy.rig import make_campaign
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
    # a format-0 log carries no design record: the replay rebuilds the design here, whose BLAS
    # decides its last bits (docs/determinism.md), so the controller agrees to round-off only:
    # bit-exact on the machine that wrote it, 3.6e-15 V in V_cmd on an Intel Xeon
    code, out, err = cli(capsys, "replay", FIXTURE_V0, "--json")
    res = json.loads(out)
    assert res["design"]["source"] == "rebuilt" and code in (0, 1), err
    assert res["bit_exact"] is True or res["max_abs_diff"] < 1e-9, res["max_abs_diff_by_signal"]
    code, out, err = cli(capsys, "inspect", FIXTURE_V0, "-o", tmp_path / "v0.rrd", "--json")
    assert code == 0 and json.loads(out)["ticks"] == 420, err


def write_with_mcap_ros2(dst, src, records=("test", "frictionrt"), topics=None):
    """src's topics (or those named) as a lab's ROS 2 recorder would write them: mcap_ros2's
    Writer, one dict per message with the documented fields (stamp, tick, the signals' ROS 2
    names and types), the documented schema names and texts, sequence 0, only the metadata
    records named (never "signals": its defaults apply)."""
    from mcap_ros2.writer import Writer
    rec = read_mcap(src)
    with open(src, "rb") as f:
        meta = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    tps = [tp for tp in topics_of(rec.signals) if tp.name in (topics or rec.topics)]
    t = rec.start_ns + tick_time_ns(rec.k, rec.rate_hz)
    with open(dst, "wb") as f:
        w = Writer(f)
        schemas = {tp.name: w.register_msgdef(tp.schema_name, tp.schema_text.decode()) for tp in tps}
        for name in records:
            w.add_metadata(name, meta[name])
        cast = {"float64": float, "bool": bool}
        for i, k in enumerate(rec.k):
            stamp = {"sec": int(t[i]) // 10**9, "nanosec": int(t[i]) % 10**9}
            for tp in tps:
                msg = {"stamp": stamp, "tick": int(k)}
                msg.update((f, cast.get(typ, int)(rec.log[i, c])) for f, typ, c in zip(tp.fields, tp.types, tp.columns))
                w.write_message(tp.name, schemas[tp.name], msg, log_time=int(t[i]))
        w.finish()
    return dst


def test_a_file_written_with_mcap_ros2_is_validated_and_replayed(run_log, tmp_path, capsys):
    capsys.readouterr()
    f = write_with_mcap_ros2(tmp_path / "lab.mcap", run_log)
    assert validate(f) == []
    a, b = read_mcap(run_log), read_mcap(f)
    # without the signals record the columns are in topic order, named back from their fields
    assert sorted(b.signals) == sorted(a.signals) and b.rate_hz == a.rate_hz and b.start_ns == a.start_ns
    cols = [a.signals.index(s) for s in b.signals]
    np.testing.assert_array_equal(b.log.view(np.uint64), a.log[:, cols].view(np.uint64))
    code, out, err = cli(capsys, "replay", f, "--json")
    assert code == 0 and json.loads(out)["bit_exact"] is True, err
    # a measurement: the required topics only, no frictionrt record
    m = write_with_mcap_ros2(tmp_path / "meas.mcap", run_log, records=("test",),
                             topics=("/rt", "/sensors", "/tracking", "/actuator"))
    assert validate(m) == []
    code, out, err = cli(capsys, "replay", m, "--json")
    assert code == 0 and json.loads(out)["ticks"] == 1050, err
    # without the test record: named, with what to add
    n = write_with_mcap_ros2(tmp_path / "none.mcap", run_log, records=(), topics=("/rt", "/sensors", "/actuator"))
    problems = validate(n)
    assert [(p.where, p.kind) for p in problems] == [("metadata test", "missing")]
    assert "add_metadata(\"test\"" in problems[0].detail


def test_diagnose_reads_a_campaign_written_with_mcap_ros2(tmp_path):
    from frictionrt.rt.common.config import load
    from frictionrt.rt.discrepancy.diagnose import load_campaign
    from frictionrt.rt.discrepancy.rig import make_campaign
    files = make_campaign(tmp_path / "camp", record_s=0.01, levels_n=(100.0,), ramps_s=(3e-3,), cfg=load())
    (tmp_path / "lab").mkdir()
    for p in files:
        write_with_mcap_ros2(tmp_path / "lab" / p.name, p, records=("test",))
        assert validate(tmp_path / "lab" / p.name) == []
    ours, lab = load_campaign(tmp_path / "camp"), load_campaign(tmp_path / "lab")
    assert [(t.name, t.kind, t.dt) for t in lab] == [(t.name, t.kind, t.dt) for t in ours]
    for t, u in zip(ours, lab):
        assert sorted(t.data) == sorted(u.data)
        for name in t.data:
            np.testing.assert_array_equal(u.data[name], t.data[name])


def test_simulate_writes_a_foxglove_layout_of_the_blueprints_panels(run_log):
    from tests.test_crash_safety import FULL_VIEWS, view_names
    layout = json.loads(run_log.with_name("run.foxglove.json").read_text())
    panels = layout["configById"]
    plots = {k: p for k, p in panels.items() if k.startswith("Plot!")}
    tabs = {t["title"] for t in panels[layout["layout"]]["tabs"]}
    damper = {"F_N1 setpoint vs measured", "friction hysteresis: F_t [N] up vs u_rel [um]"}   # rerun's titles
    assert view_names(run_log.with_suffix(".rrd")) == FULL_VIEWS == tabs | damper
    assert {p["title"] for p in plots.values()} == tabs - {"damper"} | {"F_N1 setpoint vs measured",
                                                                         "friction hysteresis: F_t [N] vs u_rel"}
    # every message path is a field of the file as the ROS 2 decoder sees it; every signal is in its tab
    fields = {t: set(f) - {"tick"} for t, (_, _, f) in ros2_decode(run_log).items() if t != KF_TOPIC}  # no plot
    for p in (p["value"] for plot in plots.values() for p in plot["paths"]):
        topic, field = p.split(".")
        assert field in fields[topic], p
    for topic, f in fields.items():
        assert {p["value"] for p in plots[f"Plot!{topic[1:]}"]["paths"]} == {f"{topic}.{x}" for x in f}
    assert [p["value"] for p in plots["Plot!setpoint"]["paths"]] == [
        "/tracking.f_set", "/tracking.f_set_filtered", "/plant.f_n1", "/sensors.f_strain", "/sensors.f_cell"]
    assert plots["Plot!hysteresis"]["xAxisPath"]["value"] == "/plant.u_rel"


FOXGLOVE_CHECK = Path(os.environ.get("FOXGLOVE_CHECK_DIR") or Path(__file__).parents[1] / "tools" / "foxglove")
"""Foxglove's own decoder (check.mjs in the clone's tools/foxglove; FOXGLOVE_CHECK_DIR: a copy elsewhere),
usable after ``make foxglove`` (``npm ci`` there; Node.js)."""


@pytest.mark.skipif(shutil.which("node") is None or not (FOXGLOVE_CHECK / "node_modules").is_dir(),
                    reason=f"Foxglove's parser needs Node.js and `make foxglove` (npm ci in {FOXGLOVE_CHECK}), "
                           "or FOXGLOVE_CHECK_DIR naming a folder where npm install ran")
def test_foxglove_parses_every_schema_and_decodes_every_message(run_log):
    out = subprocess.run(["node", "check.mjs", str(run_log)], cwd=FOXGLOVE_CHECK, capture_output=True, text=True,
                         timeout=120).stdout
    assert 'profile: "ros2"' in out and "schema FAIL" not in out
    assert out.count("schema ok:") == 7 and "messages decoded 6301" in out   # 6 topics x 1050, 1 key frame
    assert "schema ok: frictionrt/msg/Keyframe" in out


AFTER_2020_NS = 1_577_836_800 * 10**9   # 2020-01-01T00:00:00Z [ns since 1970]


def _first_mcap_time_ns(path) -> int:
    with open(path, "rb") as f:
        return make_reader(f).get_summary().statistics.message_start_time


def _first_rrd_time_ns(path) -> int:
    """The earliest time of the recording's "utc" timeline [ns since 1970] (0 if it has none)."""
    from rerun.chunk import RrdReader
    first = []
    for c in RrdReader(path).stream().to_chunks():
        rb = c.to_record_batch()
        if "utc" in rb.schema.names:
            first.append(rb.column("utc").cast("int64").to_numpy().min())
    return int(min(first)) if first else 0


def test_every_log_the_project_writes_starts_after_2020(tmp_path, capsys, run_log):
    """Real UTC stamps, so that Foxglove and rerun show real dates: the first log time of simulate's
    MCAP and .rrd, a rig campaign's measurements, a recovered log and inspect's .rrd of a campaign
    file (its UTC from the file) are all after 2020-01-01."""
    from frictionrt.rt.common.config import load
    from frictionrt.rt.discrepancy.rig import make_campaign
    logs = {"simulate mcap": _first_mcap_time_ns(run_log), "simulate rrd": _first_rrd_time_ns(run_log.with_suffix(".rrd"))}
    files = make_campaign(tmp_path / "camp", record_s=0.01, levels_n=(100.0,), ramps_s=(3e-3,), cfg=load())
    logs |= {f"rig {f.name}": _first_mcap_time_ns(f) for f in files if f.suffix == ".mcap"}
    assert cli(capsys, "recover", run_log, "-o", tmp_path / "rec.mcap")[0] == 0
    logs["recover"] = _first_mcap_time_ns(tmp_path / "rec.mcap")
    assert cli(capsys, "inspect", files[0], "-o", tmp_path / "meas.rrd")[0] == 0
    logs["inspect rrd"] = _first_rrd_time_ns(tmp_path / "meas.rrd")
    late = {name: t for name, t in logs.items() if not t > AFTER_2020_NS}
    assert len(logs) >= 6 and not late, late


def test_inspect_writes_the_foxglove_layout_beside_its_rrd(tmp_path, capsys, run_log):
    """As simulate does: NAME.foxglove.json beside NAME.rrd, the same panels for the same signals; an
    existing layout is refused without --force like the recording."""
    code, out, err = cli(capsys, "inspect", run_log, "-o", tmp_path / "view.rrd", "--json")
    layout = tmp_path / "view.foxglove.json"
    assert code == 0 and json.loads(out)["foxglove_layout"] == str(layout), err
    assert json.loads(layout.read_text()) == json.loads(run_log.with_suffix(".foxglove.json").read_text())
    (tmp_path / "view.rrd").unlink()
    code, _, err = cli(capsys, "inspect", run_log, "-o", tmp_path / "view.rrd")
    assert code == 2 and "view.foxglove.json" in err and "--force" in err
    assert cli(capsys, "inspect", run_log, "-o", tmp_path / "view.rrd", "--force")[0] == 0
