"""The measurement format (rt.log.data_format, docs/data-format.md, frictionrt validate): the registry
agrees with the loop's signals in both directions, the doc's tables are the generated ones, the
project's logs validate clean with their test record, and crafted files with one defect each are
named (topic/field/metadata and kind); unreadable files exit 2."""
import json
import re
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import CompressionType, Writer

from frictionrt.rt.cli import main
from frictionrt.rt.log.data_format import (REQUIRED, SETPOINTS, SIGNALS, entry_of, required_table, signal_table,
                            keys_table, validate)
from frictionrt.rt.loop import loop_signals
from frictionrt.rt.log.mcap_log import read_mcap, signals_record, stamps_ns, topics_of
from frictionrt.rt.log.registry import field_type, ros2_field
from frictionrt.tracking.force_tracking import design_force_tracking

DOC = Path(__file__).resolve().parents[1] / "docs" / "data-format.md"


def simulate(path, law, estimator="oracle", duration="0.05"):
    code = main(["simulate", "--law", law, "--estimator", estimator, "--freq", "196", "--amp", "5",
                 "--duration", duration, "--out", str(path), "--no-rrd", "--json"])
    assert code == 0
    return path.with_name(path.name + ".mcap")


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    return {"hysteresis": simulate(d / "hyst", "hysteresis"), "passive": simulate(d / "pass", "passive")}


def validate_cli(capsys, path):
    code = main(["validate", str(path), "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out else None), out.err


# --- the registry and the doc ------------------------------------------------------------------

def test_registry_matches_the_loop_signals_both_ways(reduced):
    sig = loop_signals(reduced)
    for name, unit, owner in sig:  # every logged signal is documented, with its unit
        e = entry_of(owner, name)
        assert e is not None, f"/{owner}.{name} is not in rt.log.data_format.SIGNALS"
        assert e.unit == unit, (name, e.unit, unit)
    used = {entry_of(o, n) for n, _, o in sig}
    assert set(SIGNALS) == used  # and every documented signal is logged
    names = {n: (u, o) for n, u, o in sig}
    for n in REQUIRED + SETPOINTS:  # required fields exist in the loop with the documented unit and topic
        e = next(e for e in SIGNALS if e.name == n)
        assert names[n] == (e.unit, e.owner)
    # the piezo stack's voltage and current are logged (required for a measurement)
    assert names["V_a"] == ("V", "actuator") and names["i"] == ("A", "actuator")


@pytest.mark.parametrize("marker, table", [("signal-table", signal_table), ("required-table", required_table),
                                           ("test-table", keys_table)])
def test_doc_tables_are_the_generated_ones(marker, table):
    text = DOC.read_text()
    m = re.search(rf"<!-- {marker}[^>]*-->\n(.*?)<!-- /{marker} -->", text, re.S)
    assert m, f"docs/data-format.md lacks the {marker} block"
    assert m.group(1) == table(), f"regenerate the {marker} of docs/data-format.md: python -m frictionrt.rt.log.data_format"


def test_doc_required_fields_exist_in_the_loop(reduced):
    """Parsed from the doc itself: every required field listed there is a loop signal with that
    unit and topic, and every required field of the code is listed."""
    text = DOC.read_text()
    block = re.search(r"<!-- required-table -->\n(.*?)<!-- /required-table -->", text, re.S).group(1)
    rows = re.findall(r"\| /(\w+) \| `(\w+)` \| `(\w+)` \| (\w+) \| ([^|]+) \|", block)
    sig = {n: (u, o) for n, u, o in loop_signals(reduced)}
    assert {n for _, n, _, _, _ in rows} == set(REQUIRED + SETPOINTS)
    for owner, name, field, typ, unit in rows:
        assert sig[name] == (unit.strip(), owner) and field == ros2_field(name) and typ == field_type(name, owner)


# --- the project's logs -------------------------------------------------------------------------

@pytest.mark.parametrize("law", ["hysteresis", "passive"])
def test_project_logs_validate_clean(logs, capsys, law):
    assert validate(logs[law]) == []
    code, r, _ = validate_cli(capsys, logs[law])
    assert code == 0 and r == {"file": str(logs[law]), "valid": True, "problems": []}


def test_simulate_writes_the_test_record(logs, cfg):
    from mcap.reader import make_reader
    with open(logs["hysteresis"], "rb") as f:
        test = {m.name: m.metadata for m in make_reader(f).iter_metadata()}["test"]
    x = {p.name: p.x_m for p in cfg.plant.points}
    assert test["kind"] == "step-sine" and json.loads(test["freq_hz"]) == [196.0]
    assert float(test["excitation_x_m"]) == x["exc"] == 0.325
    assert json.loads(test["sensor_positions_m"]) == {"a_tip_meas": x["tip"], "a_frf_meas": x["frf"],
                                                      "F_strain": 0.615, "F_cell": 0.615}
    assert test["law"] == "hysteresis" and test["force_sensor"] == "strain"
    gains = json.loads(test["gains"])
    assert gains["K_f_N_per_m"] == cfg.tracking.K_f and gains["T1_s"] == cfg.tracking.T1_s
    assert gains["Ki_V_per_Ns"] == design_force_tracking(cfg, "strain").Ki > 0  # the designed tracking loop (pure I)
    assert float(test["amplitude_n"]) == 5.0 and float(test["duration_s"]) == 0.05


# --- crafted files ------------------------------------------------------------------------------

def craft(path, src, *, drop_topics=(), drop_records=(), k=None, log=None, signals=None, schema=None):
    """src's messages and metadata rewritten with the mcap library (as a lab converter would),
    with one change: topics or records left out, other ticks k (rows of log), other signals
    (units), or a replaced schema text per topic."""
    from mcap.reader import make_reader
    rec = read_mcap(src)
    with open(src, "rb") as f:
        records = {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}
    signals = rec.signals if signals is None else signals
    records["signals"] = signals_record(signals, rec.rate_hz, rec.start_ns)
    log = rec.log if log is None else log
    k = rec.k if k is None else np.asarray(k)
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start()
        chans = []
        for tp in topics_of(signals):
            if tp.name in drop_topics:
                continue
            text = (schema or {}).get(tp.name, tp.schema_text)
            chans.append((w.register_channel(tp.name, "cdr", w.register_schema(tp.schema_name, "ros2msg", text)), tp))
        for name, r in records.items():
            if name not in drop_records:
                w.add_metadata(name, r)
        t = stamps_ns(k, rec.rate_hz, rec.start_ns)
        msgs = [(ch, tp.encode(k, t, log)) for ch, tp in chans]
        for i, kk in enumerate(k):
            for ch, m in msgs:
                w.add_message(ch, int(t[i]), m[i].tobytes(), int(t[i]), int(kk) % 2**32)
        w.finish()
    return path


def problems_of(capsys, path):
    code, r, _ = validate_cli(capsys, path)
    assert code == 1 and r["valid"] is False
    return {(p["where"], p["kind"]) for p in r["problems"]}, r["problems"]


def test_a_missing_topic_is_named(logs, capsys, tmp_path):
    f = craft(tmp_path / "x.mcap", logs["hysteresis"], drop_topics=("/actuator",))
    found, _ = problems_of(capsys, f)
    assert found == {("/actuator", "missing")}


def test_a_nan_sample_is_named_with_its_tick(logs, capsys, tmp_path):
    rec = read_mcap(logs["hysteresis"])
    log = rec.log.copy()
    log[321, rec.column("a_frf_meas")] = np.nan
    found, probs = problems_of(capsys, craft(tmp_path / "x.mcap", logs["hysteresis"], log=log))
    assert found == {("/sensors.a_frf_meas", "NaN")}
    assert "1 of 1050" in probs[0]["detail"] and "tick 321" in probs[0]["detail"]


def test_non_monotonic_and_duplicate_times_are_named(logs, capsys, tmp_path):
    k = np.arange(1050)
    k[500], k[501] = 501, 500   # two ticks swapped
    found, probs = problems_of(capsys, craft(tmp_path / "a.mcap", logs["hysteresis"], k=k))
    assert found == {(t, "non-monotonic time") for t in ("/rt", "/sensors", "/observer", "/tracking", "/actuator",
                                                         "/plant")}
    assert "tick 500 after tick 501" in probs[0]["detail"]
    k = np.arange(1050)
    k[700] = 699                # a tick written twice, 700 lost
    found, _ = problems_of(capsys, craft(tmp_path / "b.mcap", logs["hysteresis"], k=k))
    assert {kind for _, kind in found} == {"duplicate time"} and len(found) == 6


def test_a_missing_test_record_is_named(logs, capsys, tmp_path):
    found, _ = problems_of(capsys, craft(tmp_path / "x.mcap", logs["hysteresis"], drop_records=("test",)))
    assert found == {("metadata test", "missing")}


def test_wrong_unit_type_and_rate_are_named(logs, capsys, tmp_path):
    rec = read_mcap(logs["hysteresis"])
    sig = tuple((n, "kN" if n == "F_cell" else u, o) for n, u, o in rec.signals)
    found, _ = problems_of(capsys, craft(tmp_path / "u.mcap", logs["hysteresis"], signals=sig))
    assert found == {("/sensors.F_cell", "wrong unit")}
    tp = next(t for t in topics_of(rec.signals) if t.name == "/actuator")
    text = tp.schema_text.replace(b"float64 v_a\n", b"float32 v_a\n")
    found, _ = problems_of(capsys, craft(tmp_path / "t.mcap", logs["hysteresis"], schema={"/actuator": text}))
    assert found == {("/actuator.V_a", "wrong type")}
    # declared 21000 Hz, recorded at 10500 Hz: every 2nd tick
    found, _ = problems_of(capsys, craft(tmp_path / "r.mcap", logs["hysteresis"], k=2 * np.arange(1050)))
    assert {kind for _, kind in found} == {"wrong rate"} and len(found) == 6


def test_a_measurement_without_simulation_topics_is_valid(logs, capsys, tmp_path):
    """Only the required topics (/rt, /sensors, /actuator, /tracking with the law): valid, no
    frictionrt record needed; without /tracking but with a law in the test record: named."""
    f = craft(tmp_path / "m.mcap", logs["hysteresis"], drop_topics=("/observer", "/plant"), drop_records=("frictionrt",))
    assert validate(f) == []
    f = craft(tmp_path / "n.mcap", logs["hysteresis"], drop_topics=("/observer", "/plant", "/tracking"))
    found, _ = problems_of(capsys, f)
    assert found == {("/tracking", "missing")}


@pytest.mark.parametrize("content, problem", [(None, "no such file"), (b"", "not an MCAP file"),
                                              ("cut", "truncated")])
def test_unreadable_files_exit_2_naming_the_file(logs, capsys, tmp_path, content, problem):
    f = tmp_path / "bad.mcap"
    if content == "cut":
        f.write_bytes(logs["passive"].read_bytes()[:-100])
    elif content is not None:
        f.write_bytes(content)
    code, out, err = validate_cli(capsys, f)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and str(f) in lines[0] and problem in lines[0]
    assert out == {"error": lines[0].removeprefix("frictionrt: error: "), "exit": 2}   # --json: the error as JSON
