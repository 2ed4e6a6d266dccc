"""Log files: MCAP (rt.log.mcap_log) bit-exact round trip, time rule, layout and errors; rrd (rt.log.rrd_log)."""
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from frictionrt.rt.loop import loop_signals
from frictionrt.rt.log.mcap_log import (CDR_LE, FORMAT_VERSION, McapLogWriter, read_mcap, signals_record, stamps_ns, tick_time_ns,
                         topics_of)
from frictionrt.rt.log.registry import FIELD_RE, field_names, field_type, ros2_field, signal_name
from frictionrt.rt.log.rrd_log import RrdLogWriter, write_rrd

RATE = 21000
META = {"config": "[rt]\nrate_hz = 21000.0  # Hz\n", "versions": "numpy 2.4, mcap 1.6.0", "seed": "7",
        "start_utc": "2026-01-01T00:00:00.250+00:00", "command": "frictionrt simulate --law lyapunov µ"}
START_NS = 1767225600_250_000_000   # META's start_utc [ns since 1970]
INT_RANGE = {"bool": (0, 2), "int8": (-128, 128), "int32": (-2**31, 2**31), "int64": (-2**53, 2**53)}


@pytest.fixture(scope="module")
def signals(reduced):
    return loop_signals(reduced)


def special_log(n: int, signals, seed: int = 0) -> np.ndarray:
    """Random values plus every float64 corner: +-0, +-inf, NaNs with payloads, denormals,
    extremes (n >= 8) in the float64 fields; whole numbers over the range of the integer and
    bool fields (their extremes included)."""
    n_sig = len(signals)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((n, n_sig)) * 10.0 ** rng.uniform(-9, 9, n_sig)
    corners = np.array([-0.0, 0.0, np.inf, -np.inf, np.nan, 5e-324, -2.2e-308, 1.7976931348623157e308])
    x[:len(corners), 0] = corners
    x[1, :] = corners[np.arange(n_sig) % len(corners)]
    types = [field_type(name, owner) for name, _, owner in signals]
    last = max(c for c, t in enumerate(types) if t == "float64")
    x[2, last] = np.array(0x7FF8_0000_0000_0123, dtype=np.uint64).view(np.float64)   # quiet NaN, payload
    x[3, last] = np.array(0xFFF0_0000_0000_0001, dtype=np.uint64).view(np.float64)   # signalling NaN, sign
    for c, typ in enumerate(types):
        if typ != "float64":
            lo, hi = INT_RANGE[typ]
            x[:, c] = rng.integers(lo, hi, n)
            x[:2, c] = lo, hi - 1
    return x


def write(path, signals, log, k0=0, block=None, metadata=META):
    with McapLogWriter(path, signals, RATE, metadata) as w:
        step = block or len(log)
        for i in range(0, len(log), step):
            w.write_block(k0 + i, log[i:i + step])


def raw_messages(path):
    with open(path, "rb") as f:
        return [(ch.topic, m.log_time, m.publish_time, m.sequence, bytes(m.data))
                for _, ch, m in make_reader(f).iter_messages(log_time_order=False)]


def test_round_trip_is_bit_exact(tmp_path, signals):
    log = special_log(1500, signals)
    write(tmp_path / "a.mcap", signals, log)
    back = read_mcap(tmp_path / "a.mcap")
    assert back.signals == signals and back.rate_hz == RATE
    assert back.topics == ("/rt", "/sensors", "/observer", "/tracking", "/actuator", "/plant")
    np.testing.assert_array_equal(back.k, np.arange(1500))
    np.testing.assert_array_equal(back.log.view(np.uint64), log.view(np.uint64))


def test_chunk_reader_equals_the_mcap_library_reader(tmp_path, signals, monkeypatch):
    # read_mcap's numpy chunk walk (rt.log.mcap_log.chunk_messages) against the library's own
    # message iteration on the same file: bit-identical values and ticks, several chunks
    import frictionrt.rt.log.mcap_log as mcap_log
    log = special_log(12000, signals, seed=3)
    write(tmp_path / "a.mcap", signals, log, block=997)
    with open(tmp_path / "a.mcap", "rb") as f:
        assert len(make_reader(f).get_summary().chunk_indexes) >= 5
    fast = read_mcap(tmp_path / "a.mcap")
    def library(f, summary):
        f.seek(0)
        return mcap_log.iter_messages(make_reader(f))
    monkeypatch.setattr(mcap_log, "chunk_messages", library)
    slow = read_mcap(tmp_path / "a.mcap")
    np.testing.assert_array_equal(fast.k, slow.k)
    np.testing.assert_array_equal(fast.log.view(np.uint64), slow.log.view(np.uint64))
    np.testing.assert_array_equal(fast.log.view(np.uint64), log.view(np.uint64))


def test_a_corrupt_chunk_is_refused_by_its_crc(tmp_path, signals):
    log = special_log(3000, signals, seed=4)
    write(tmp_path / "a.mcap", signals, log)
    with open(tmp_path / "a.mcap", "rb") as f:
        ci = make_reader(f).get_summary().chunk_indexes[0]
    data = bytearray((tmp_path / "a.mcap").read_bytes())
    data[ci.chunk_start_offset + ci.chunk_length // 2] ^= 0x40     # inside the compressed records
    (tmp_path / "b.mcap").write_bytes(bytes(data))
    with pytest.raises(ValueError, match="b.mcap: unreadable MCAP log"):
        read_mcap(tmp_path / "b.mcap")


def cdr(fields) -> bytes:
    """An independent CDR encoder: little-endian header, then each (struct format, value) aligned
    to its size relative to the end of the header."""
    out = bytearray()
    for fmt, v in fields:
        out += bytes(-len(out) % struct.calcsize(fmt)) + struct.pack("<" + fmt, v)
    return CDR_LE + bytes(out)


FMT = {"float64": "d", "int64": "q", "int32": "i", "int8": "b", "bool": "?"}


def test_messages_are_cdr_of_the_owners_columns_at_exact_tick_times(tmp_path, signals):
    # k0 beyond 2**32 (sequence wraps) and k * 1e9 beyond 2**53 (float times would be inexact)
    k0, n = 9_000_000_000, 40
    log = special_log(n, signals, seed=1)
    write(tmp_path / "a.mcap", signals, log, k0=k0)
    msgs = raw_messages(tmp_path / "a.mcap")
    topics = topics_of(signals)
    assert len(msgs) == n * len(topics)
    for j, (topic, log_time, publish_time, seq, data) in enumerate(msgs):
        i, tp = divmod(j, len(topics))
        k = k0 + i
        assert topic == topics[tp].name
        assert log_time == publish_time == START_NS + k * 10**9 // RATE       # Python ints: exact
        assert seq == k % 2**32
        fields = [("i", log_time // 10**9), ("I", log_time % 10**9), ("q", k)]
        for c in topics[tp].columns:
            name, _, owner = signals[c]
            typ = field_type(name, owner)
            fields.append((FMT[typ], log[i, c] if typ == "float64" else int(log[i, c])))
        assert data == cdr(fields)   # independent encoder
    back = read_mcap(tmp_path / "a.mcap")
    assert back.start_ns == START_NS and back.version == FORMAT_VERSION
    np.testing.assert_array_equal(back.k, k0 + np.arange(n))
    np.testing.assert_array_equal(tick_time_ns(back.k, RATE), [k * 10**9 // RATE for k in range(k0, k0 + n)])


def test_an_independent_ros2_decoder_reads_fields_by_name(tmp_path, signals):
    # rerun's MCAP reader (Rust) with its ROS 2 message-definition decoder, as Foxglove decodes
    from rerun.chunk import McapReader

    log = special_log(1200, signals, seed=5)
    write(tmp_path / "a.mcap", signals, log, block=500)
    reader = McapReader(tmp_path / "a.mcap", timeline_type="duration_ns", decoders=["ros2_reflection"],
                        include_topic_regex=["^/tracking$"])
    t, v = [], []
    for c in reader.stream().to_chunks():
        rb = c.to_record_batch()
        t.append(rb.column("message_log_time").cast("int64").to_numpy())
        v.append(rb.column("frictionrt.msg.Tracking:message").flatten().field("f_set_filtered").to_numpy())
    t, v = np.concatenate(t), np.concatenate(v)
    np.testing.assert_array_equal(t, START_NS + np.arange(1200) * 10**9 // RATE)
    col = [n for n, _, _ in signals].index("F_set_filtered")
    np.testing.assert_array_equal(v.view(np.uint64), log[:, col].view(np.uint64))


def test_blocks_write_the_same_file_content_as_one_block(tmp_path, signals):
    log = special_log(1000, signals, seed=2)
    write(tmp_path / "one.mcap", signals, log, k0=5)
    write(tmp_path / "blocks.mcap", signals, log, k0=5, block=137)
    assert raw_messages(tmp_path / "one.mcap") == raw_messages(tmp_path / "blocks.mcap")
    a, b = read_mcap(tmp_path / "one.mcap"), read_mcap(tmp_path / "blocks.mcap")
    np.testing.assert_array_equal(a.log.view(np.uint64), b.log.view(np.uint64))


def test_schemas_list_the_fields_of_each_owner(tmp_path, signals):
    write(tmp_path / "a.mcap", signals, special_log(8, signals))
    with open(tmp_path / "a.mcap", "rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
    by_topic = {ch.topic: (ch, summary.schemas[ch.schema_id]) for ch in summary.channels.values()}
    for owner in ("rt", "sensors", "observer", "tracking", "actuator", "plant"):
        ch, schema = by_topic["/" + owner]
        assert ch.message_encoding == "cdr" and schema.encoding == "ros2msg"
        assert schema.name == f"frictionrt/msg/{owner.capitalize()}"
        assert schema.data.decode().splitlines() == [
            "builtin_interfaces/Time stamp", "int64 tick",
            *[f"{field_type(n, o)} {ros2_field(n)}" for n, _, o in signals if o == owner],
            "=" * 80, "MSG: builtin_interfaces/Time", "int32 sec", "uint32 nanosec"]
    assert "float64 f_set_filtered" in by_topic["/tracking"][1].data.decode()
    assert "bool passive" in by_topic["/rt"][1].data.decode()


def test_metadata_round_trip(tmp_path, signals):
    write(tmp_path / "a.mcap", signals, special_log(8, signals))
    back = read_mcap(tmp_path / "a.mcap")
    assert back.metadata == META
    with open(tmp_path / "a.mcap", "rb") as f:
        rec = {m.name: m.metadata for m in make_reader(f).iter_metadata()}["signals"]
    assert rec["rate_hz"] == "21000" and float(rec["dt_s"]) == 1 / 21000
    assert rec["format_version"] == str(FORMAT_VERSION) and rec["start_ns"] == str(START_NS)


def test_every_loop_signal_maps_to_a_unique_ros2_field_and_back(signals, full):
    # the rule (rt.log.registry): lower-casing plus the exceptions; both plant models, so that a new
    # plant or actuator signal is covered once it is in rt.loop.build.loop_signals
    for sig in (signals, loop_signals(full)):
        fields = field_names(sig)
        assert len(set(zip(fields, (o for _, _, o in sig)))) == len(sig)
        assert all(FIELD_RE.match(f) for f in fields)
        assert [signal_name(f, o) for f, (_, _, o) in zip(fields, sig)] == [n for n, _, _ in sig]
    assert ros2_field("F_N1") == "f_n1" and ros2_field("V_cmd") == "v_cmd" and ros2_field("E_fric") == "e_fric"
    assert ros2_field("W_exc") == "work_exc" and signal_name("w_exc", "plant") == "w_exc"
    assert signal_name("work_exc", "plant") == "W_exc" and signal_name("g_n_3", "plant") == "g_n_3"
    assert signal_name("unknown_x", "plant") == "unknown_x"


@pytest.mark.parametrize("sig, problem", [
    ((("a b", "-", "rt"),), "'a b' has no valid ROS 2 field"), ((("1x", "-", "rt"),), "'1x' has no valid"),
    ((("a__b", "-", "rt"),), "'a__b' has no valid"), ((("x_", "-", "rt"),), "'x_' has no valid"),
    ((("tick", "-", "rt"),), "'tick' has no valid"),
    ((("A_b", "-", "rt"), ("a_B", "-", "rt")), "'A_b' and 'a_B' of /rt both map to the field 'a_b'")])
def test_a_signal_without_a_ros2_field_is_refused_naming_the_file(tmp_path, sig, problem):
    with pytest.raises(ValueError, match=f"a.mcap: .*{problem}"):
        McapLogWriter(tmp_path / "a.mcap", sig, RATE, META)
    assert list(tmp_path.iterdir()) == []


def test_an_integer_field_refuses_a_value_it_cannot_hold(tmp_path, signals):
    log = np.zeros((3, len(signals)))
    log[1, [n for n, _, _ in signals].index("newton_iter")] = 2.5
    with pytest.raises(ValueError, match=r"a.mcap: signal newton_iter \(int32 newton_iter\) is 2.5 at tick 1"), \
            McapLogWriter(tmp_path / "a.mcap", signals, RATE, META) as w:
        w.write_block(0, log)


def raw_file(path, signals, messages, schema_text=None):
    """An MCAP file written with mcap's own writer: the frictionrt signals record and the given
    messages [(owner, k, values)] (e.g. measured data: only /sensors)."""
    topics = {tp.owner: tp for tp in topics_of(signals)}
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start()
        channels = {}
        for owner in dict.fromkeys(o for o, _, _ in messages):
            tp = topics[owner]
            sid = w.register_schema(tp.schema_name, "ros2msg", schema_text or tp.schema_text)
            channels[owner] = w.register_channel(tp.name, "cdr", sid)
        w.add_metadata("signals", signals_record(signals, RATE))
        for owner, k, values in messages:
            tp = topics[owner]
            row = np.zeros((1, len(signals)))
            row[0, tp.columns] = values
            t = stamps_ns(np.array([k]), RATE, 0)
            w.add_message(channels[owner], int(t[0]), tp.encode(np.array([k]), t, row).tobytes(), int(t[0]), k)
        w.finish()


def test_missing_topics_read_as_nan(tmp_path, signals):
    sensors = topics_of(signals)[1]
    assert sensors.name == "/sensors"
    vals = np.random.default_rng(3).standard_normal((50, len(sensors.columns)))
    raw_file(tmp_path / "meas.mcap", signals, [("sensors", 100 + i, v) for i, v in enumerate(vals)])
    back = read_mcap(tmp_path / "meas.mcap")
    assert back.topics == ("/sensors",) and back.metadata == {}
    np.testing.assert_array_equal(back.k, 100 + np.arange(50))
    np.testing.assert_array_equal(back.log[:, sensors.columns], vals)
    others = np.setdiff1d(np.arange(len(signals)), sensors.columns)
    assert np.isnan(back.log[:, others]).all()


@pytest.mark.parametrize("ticks, problem", [([0, 1, 1, 2], "duplicated ticks"),
                                            ([0, 2, 1, 3], "not increasing")])
def test_bad_ticks_are_refused(tmp_path, signals, ticks, problem):
    m = len(topics_of(signals)[1].columns)
    raw_file(tmp_path / "bad.mcap", signals, [("sensors", k, np.zeros(m)) for k in ticks])
    with pytest.raises(ValueError, match=f"bad.mcap.*{problem}"):
        read_mcap(tmp_path / "bad.mcap")


def test_schema_mismatch_is_refused(tmp_path, signals):
    m = len(topics_of(signals)[1].columns)
    raw_file(tmp_path / "bad.mcap", signals, [("sensors", 0, np.zeros(m))], schema_text=b"float64 x\n")
    with pytest.raises(ValueError, match="bad.mcap.*schema of /sensors does not match"):
        read_mcap(tmp_path / "bad.mcap")


def test_truncated_and_foreign_files_are_refused_naming_the_file(tmp_path, signals):
    write(tmp_path / "a.mcap", signals, special_log(500, signals))
    data = (tmp_path / "a.mcap").read_bytes()
    for cut in (1, 100, len(data) // 2, len(data) - 9):
        (tmp_path / "cut.mcap").write_bytes(data[:-cut])
        with pytest.raises(ValueError, match="cut.mcap.*truncated"):
            read_mcap(tmp_path / "cut.mcap")
    (tmp_path / "text.mcap").write_text("time,F_N1\n0,100\n")
    with pytest.raises(ValueError, match="text.mcap.*not an MCAP file"):
        read_mcap(tmp_path / "text.mcap")
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(ValueError, match="empty.mcap.*not an MCAP file"):
        read_mcap(tmp_path / "empty.mcap")


def test_no_part_file_after_close_and_after_an_exception(tmp_path, signals):
    log = special_log(300, signals)
    write(tmp_path / "a.mcap", signals, log)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mcap"]
    with pytest.raises(KeyboardInterrupt), McapLogWriter(tmp_path / "b.mcap", signals, RATE, META) as w:
        w.write_block(0, log[:200])
        assert (tmp_path / "b.mcap.part").exists() and not (tmp_path / "b.mcap").exists()
        raise KeyboardInterrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mcap", "b.mcap"]
    back = read_mcap(tmp_path / "b.mcap")  # the ticks written before the interrupt
    np.testing.assert_array_equal(back.log.view(np.uint64), log[:200].view(np.uint64))


def test_writer_refuses_bad_blocks(tmp_path, signals):
    with McapLogWriter(tmp_path / "a.mcap", signals, RATE, META) as w:
        w.write_block(0, np.zeros((10, len(signals))))
        with pytest.raises(ValueError, match="a.mcap.*must start at >= 10"):
            w.write_block(5, np.zeros((10, len(signals))))
        with pytest.raises(ValueError, match="a.mcap.*float64"):
            w.write_block(10, np.zeros((10, len(signals) - 1)))
    with pytest.raises(ValueError, match="b.mcap.*whole number"):
        McapLogWriter(tmp_path / "b.mcap", signals, 21000.5, META)


# --- rrd -------------------------------------------------------------------------------------------

def rrd_column(path, series):
    """(tick, t [ns], values) of one signal "/<owner>/<name>" of an .rrd: the series of the
    entity /<owner> that its static SeriesLines names by the signal's ROS 2 field, read back with
    rerun's chunk reader."""
    from rerun.chunk import RrdReader

    entity, name = series.rsplit("/", 1)
    chunks = [c for c in RrdReader(path).stream().to_chunks() if c.entity_path == entity]
    names = next(c.to_record_batch().column("SeriesLines:names")[0].as_py() for c in chunks if c.is_static)
    j = names.index(ros2_field(name))
    ticks, times, values = [], [], []
    for c in chunks:
        if not c.is_static:
            rb = c.to_record_batch()
            ticks.append(rb.column("tick").to_numpy())
            times.append(rb.column("t").cast("int64").to_numpy())
            values.append(np.stack(rb.column("Scalars:scalars").to_numpy(zero_copy_only=False))[:, j])
    order = np.argsort(np.concatenate(ticks))
    return tuple(np.concatenate(x)[order] for x in (ticks, times, values))


def test_rrd_is_written_and_reads_back(tmp_path, signals):
    from rerun.chunk import RrdReader

    log = special_log(2000, signals, seed=4)
    write_rrd(tmp_path / "a.rrd", signals, log, RATE, k0=10, block_ticks=700, metadata=META)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.rrd"]
    assert (tmp_path / "a.rrd").stat().st_size > 0
    assert len(RrdReader(tmp_path / "a.rrd").blueprints()) == 1
    k, t, v = rrd_column(tmp_path / "a.rrd", "/plant/v_rel")
    np.testing.assert_array_equal(k, 10 + np.arange(2000))
    subprocess.run([str(Path(sys.executable).parent / "rerun"), "rrd", "verify", str(tmp_path / "a.rrd")],
                   check=True, capture_output=True)
    np.testing.assert_array_equal(t, (k * 10**9) // RATE)
    names = [n for n, _, _ in signals]
    np.testing.assert_array_equal(v.view(np.uint64), log[:, names.index("v_rel")].view(np.uint64))
    # the hysteresis points: (u_rel [um], -sum_j f_t_j [N])
    chunks = [c.to_record_batch() for c in RrdReader(tmp_path / "a.rrd").stream().to_chunks()
              if c.entity_path == "/hysteresis"]
    tick = np.concatenate([rb.column("tick").to_numpy() for rb in chunks])
    xy = np.concatenate([np.stack(rb.column("Points2D:positions").flatten().to_numpy(zero_copy_only=False))
                         for rb in chunks])[np.argsort(tick)]
    ft = [i for i, n in enumerate(names) if n.startswith("f_t_")]
    with np.errstate(over="ignore", invalid="ignore"):
        np.testing.assert_array_equal(xy[:, 0], (1e6 * log[:, names.index("u_rel")]).astype(np.float32))
        np.testing.assert_array_equal(xy[:, 1], (-log[:, ft].sum(axis=1)).astype(np.float32))


def test_rrd_writer_closes_after_an_exception(tmp_path, signals):
    log = special_log(100, signals)
    with pytest.raises(RuntimeError), RrdLogWriter(tmp_path / "a.rrd", signals, RATE, blueprint=False) as w:
        w.write_block(0, log)
        raise RuntimeError("crash")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.rrd"]
    k, _, v = rrd_column(tmp_path / "a.rrd", "/actuator/F_stack")
    np.testing.assert_array_equal(k, np.arange(100))
    np.testing.assert_array_equal(v, log[:, [n for n, _, _ in signals].index("F_stack")])
