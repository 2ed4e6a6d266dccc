"""Open-loop plant replay (rt.loop.replay_plant, frictionrt replay --plant): a fresh run's V_cmd and
F_exc replayed into actuator and plant reproduce every /actuator and /plant signal bit for bit
(each law); a changed friction coefficient is found in the plant and nowhere in the actuator
(one-way coupling); a measurement without simulation topics is replayed without comparison;
logs with gaps replay up to the gap; unsuitable files exit 2 naming the problem."""
import json

import numpy as np
import pytest

from frictionrt.plant.actuator import ACTUATOR_OUTPUTS
from frictionrt.rt.cli import main
from frictionrt.rt.common.config import adaptive_screw, load
from frictionrt.rt.log.mcap_log import read_mcap
from frictionrt.rt.loop.replay_plant import replay_plant_outputs
from frictionrt.rt.log.writer import McapBlockWriter

DURATION = "0.1"  # 2100 ticks


def simulate(path, law, estimator):
    code = main(["simulate", "--law", law, "--estimator", estimator, "--freq", "223.6", "--amp", "5",
                 "--duration", DURATION, "--out", str(path), "--no-rrd", "--json"])
    assert code == 0
    return path.with_name(path.name + ".mcap")


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    return {"passive": simulate(d / "passive", "passive", "oracle"),
            "hysteresis": simulate(d / "hysteresis", "hysteresis", "oracle"),
            "lyapunov": simulate(d / "lyapunov", "lyapunov", "observer")}


def replay(capsys, *args):
    code = main(["replay", *map(str, args), "--plant", "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out else None), out.err


@pytest.mark.parametrize("law", ["passive", "hysteresis", "lyapunov"])
def test_plant_replay_of_a_fresh_run_is_bit_exact(logs, capsys, law, reduced):
    code, r, _ = replay(capsys, logs[law])
    assert code == 0 and r["bit_exact"] is True and r["max_abs_diff"] == 0.0 and r["first_mismatch_tick"] is None
    assert r["ticks"] == 2100 and r["missing_ticks"] == 0 and r["failed_solves"] == 0 and r["law"] == law
    expected = [n for n, _ in ACTUATOR_OUTPUTS] + [n for n, _ in reduced.output_labels()]
    # 9 actuator, 117 plant: 20 of the points, energies and counters, 5 of the bolts, 4 per contact point (23)
    assert r["signals_compared"] == expected and len(expected) == 9 + 20 + 5 + 4 * reduced.n_pairs == 126
    # not vacuous: the structure moved and the stack was driven (passive: 0 V throughout; hysteresis:
    # F_N1 swings 0.65 N in 0.1 s while RT1 (T1 = 20 ms) builds up; Lyapunov: tens of N)
    assert r["outputs"]["abar_tip"]["max"] > 1.0
    swing = r["outputs"]["F_N1"]["max"] - r["outputs"]["F_N1"]["min"]
    assert swing > {"passive": -1.0, "hysteresis": 0.3, "lyapunov": 10.0}[law]


def test_a_changed_friction_coefficient_is_found_in_the_plant_only(logs, capsys, reduced):
    code, r, _ = replay(capsys, logs["lyapunov"], "--set", "plant.interface.mu=0.3")
    assert code == 1 and r["bit_exact"] is False and r["sets"] == ["plant.interface.mu=0.3"]
    by = r["max_abs_diff_by_signal"]
    # the stack is driven one-way by the recorded V_cmd: the actuator outputs stay bit-exact
    assert all(by[n] == 0.0 for n, _ in ACTUATOR_OUTPUTS)
    # the interface slips differently: its tangential forces and the accelerations change (a 1 s run
    # measured 33 m/s^2 in abar_tip, 1.2 mm/s in v_rel, 9.8 N at the point under the adaptive screw on
    # the 20 mm plant; loose lower bounds here)
    screw = adaptive_screw(load())
    j = int(np.argmin(np.abs(reduced.structure.x_pairs - screw.x_m)))
    assert by[f"f_t_{j}"] > 1.0 and by["abar_tip"] > 1.0 and by["v_rel"] > 1e-4
    assert r["first_mismatch_tick"] > 0


def test_a_measurement_replays_without_comparison_and_gives_the_plant_truth(logs, capsys, tmp_path):
    """/rt, /sensors, /tracking only: nothing to compare, but the replayed outputs are the run's own."""
    rec = read_mcap(logs["hysteresis"])
    keep = [i for i, (_, _, o) in enumerate(rec.signals) if o in ("rt", "sensors", "tracking")]
    f = tmp_path / "meas.mcap"
    with McapBlockWriter(f, [rec.signals[i] for i in keep], rec.rate_hz, rec.metadata) as w:
        w.write_block(0, np.ascontiguousarray(rec.log[:, keep]))
    code, r, _ = replay(capsys, f)
    assert code == 0 and r["bit_exact"] is None and r["signals_compared"] == [] and r["ticks"] == 2100
    _, k, out, names = replay_plant_outputs(f)
    ref = rec.log[:, [rec.column(n) for n in names]]
    np.testing.assert_array_equal(out.view(np.uint64), ref.view(np.uint64))


def test_a_log_with_a_gap_replays_up_to_the_gap(logs, capsys, tmp_path):
    rec = read_mcap(logs["hysteresis"])
    f = tmp_path / "gap.mcap"
    with McapBlockWriter(f, rec.signals, rec.rate_hz, rec.metadata) as w:
        w.write_block(0, rec.log[:1000])
        w.write_block(1200, rec.log[1200:])   # a dropped block of 200 ticks
    code, r, _ = replay(capsys, f)
    assert code == 0 and r["ticks"] == 1000 and r["missing_ticks"] == 200 and r["bit_exact"] is True


def test_unsuitable_files_exit_2_naming_the_problem(logs, capsys, tmp_path):
    rec = read_mcap(logs["passive"])
    keep = [i for i, (_, _, o) in enumerate(rec.signals) if o != "tracking"]
    f = tmp_path / "no_cmd.mcap"
    with McapBlockWriter(f, [rec.signals[i] for i in keep], rec.rate_hz, rec.metadata) as w:
        w.write_block(0, np.ascontiguousarray(rec.log[:, keep]))
    code, out, err = replay(capsys, f)
    assert code == 2 and out["exit"] == 2 and str(f) in out["error"] and "V_cmd" in err
    assert len(err.strip().splitlines()) == 1
    late = tmp_path / "late.mcap"
    with McapBlockWriter(late, rec.signals, rec.rate_hz, rec.metadata) as w:
        w.write_block(5, rec.log[5:])
    code, _, err = replay(capsys, late)
    assert code == 2 and "starts at tick 5" in err
    code, _, err = replay(capsys, tmp_path / "none.mcap")
    assert code == 2 and "no such file" in err
