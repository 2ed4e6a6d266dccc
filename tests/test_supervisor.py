"""The run-time supervisor and fault injection (rt/loop/supervisor.py, rt/loop/faults.py, docs/reliability.md):
normal runs never trip; every fault kind is detected within its stated bound, the loop is passive
in the tick of detection, no NaN reaches the actuator or plant, and the structure's response
over the fault window is never worse than the passive F_min run by more than MARGIN; latch and
auto recovery; split runs and the replay stay bit-exact with the supervisor's state."""
import json

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.plant.modes import passive_resonance_hz
from frictionrt.rt.common.config import load
from frictionrt.rt.loop.faults import schedule
from frictionrt.rt.loop import build_loop, first_harmonic_amplitude, run, summary
from frictionrt.rt.loop.supervisor import FAULT_CODES

T, K0 = 0.6, 4200          # run length [s]; faults injected at 0.2 s = tick 4200
MARGIN = 0.05              # response over the fault window at most 5 % above passive F_min's
PLANT_INPUTS = ("F_set_filtered", "V_cmd", "F_N1")  # the force command, the amplifier command, the force


@pytest.fixture(scope="module")
def cfg():
    return load()


@pytest.fixture(scope="module")
def loops(cfg):
    cache = {}

    def get(law, est, c=None):
        key = (law, est, id(c))
        if key not in cache:
            cache[key] = build_loop(c or cfg, law, est)
        return cache[key]
    return get


@pytest.fixture(scope="module")
def passive(cfg, loops):
    cache = {}

    def get(amp, freq):
        if (amp, freq) not in cache:
            cache[(amp, freq)] = run(loops("passive", "oracle"), freq, amp, T)
        return cache[(amp, freq)]
    return get


def response(r, k0, freq, dt):
    """First-harmonic amplitude of the 0.45 m acceleration [m/s^2] from tick k0 to the end."""
    return first_harmonic_amplitude(r.signal("a_frf")[k0:], freq, dt)


# --- normal runs -------------------------------------------------------------------------------

@pytest.mark.parametrize("est", ["oracle", "observer"])
@pytest.mark.parametrize("law", ["passive", "hysteresis", "lyapunov"])
def test_normal_runs_never_trip(cfg, loops, law, est):
    """5 and 20 N at the passive resonances of modes 3 and 4 (the model's own, 205.1 and 380.1 Hz):
    no check fails in any tick, and the bounded signals stay inside their bounds with margin (the
    defaults', docs/reliability.md). The passive law holds the stack's voltage: it does not track,
    and its force error (the bolt's response to the structure, up to 115 N at 20 N) is no fault."""
    L = loops(law, est)
    s = cfg.supervisor
    for amp in (5.0, 20.0):
        for freq in (passive_resonance_hz(cfg, 3), passive_resonance_hz(cfg, 4)):
            r = run(L, freq, amp, 0.5)
            assert summary(r)["trips"] == []
            assert not r.signal("fault_code").any() and not r.signal("passive").any()
            f_meas = r.signal("F_cell" if L.force_sensor == "cell" else "F_strain")
            # measured max 99 N on one machine, 110 N on another (the rattling joint at F_min:
            # the last bits decide its spikes); the bound leaves 1.3x
            if law != "passive":
                assert np.abs(r.signal("F_set_filtered") - f_meas).max() < s.tracking_error_N / 1.3
            assert np.abs(r.signal("F_strain") - r.signal("F_cell")).max() < 4 * s.force_disagree_N
            if est == "observer":
                assert np.abs(r.signal("innovation")).max() < s.innovation_bound_m_s / 3


# --- each fault kind ---------------------------------------------------------------------------

CASES = [  # spec, law, estimator, amp [N], freq [Hz], accepted codes, detection bound [ticks]
    ("sensor_dropout@0.2:0.05", "lyapunov", "observer", 5.0, 196.0, {"sensor_nonfinite"}, 0),
    ("sensor_dropout/F_cell@0.2:0.05", "lyapunov", "observer", 5.0, 196.0, {"sensor_nonfinite"}, 0),
    ("sensor_stuck@0.2", "lyapunov", "observer", 5.0, 196.0, {"sensor_stuck"}, 210),
    ("sensor_stuck/F_strain@0.2", "lyapunov", "oracle", 5.0, 196.0, {"sensor_stuck", "force_disagree"}, 210),
    ("sensor_gain=1000@0.2", "lyapunov", "observer", 5.0, 196.0, {"sensor_range"}, 107),
    ("sensor_gain/F_strain@0.2", "hysteresis", "oracle", 20.0, 196.0, {"sensor_range", "force_disagree"}, 44),
    ("sensor_bias@0.2", "lyapunov", "observer", 5.0, 196.0, {"observer_divergence"}, 300),
    ("sensor_bias/F_cell@0.2", "lyapunov", "observer", 5.0, 196.0, {"force_disagree"}, 52),
    # actuator_loss: which check trips first, and when, depends on the bang-bang law's phase at the
    # fault (measured 100 ticks on one code generation, 191 on another): bound 5 periods at 370 Hz
    ("actuator_loss@0.2", "lyapunov", "oracle", 20.0, 370.0, {"sensor_range", "tracking_error", "amp_saturation"}, 284),
    ("force_saturation@0.2", "hysteresis", "oracle", 20.0, 196.0, {"amp_saturation", "tracking_error"}, 500),
    ("observer_mismatch@0.2", "lyapunov", "observer", 5.0, 196.0, {"observer_divergence"}, 5),
]


@pytest.mark.parametrize("spec, law, est, amp, freq, codes, bound", CASES, ids=[c[0] for c in CASES])
def test_fault_detected_passive_finite_and_no_worse_than_passive(cfg, loops, passive, spec, law, est, amp, freq,
                                                                 codes, bound, capsys):
    r = run(loops(law, est), freq, amp, T, faults=schedule([spec], cfg))
    f = summary(r)["faults"][0]
    assert f["tick"] == K0
    assert f["name"] in codes and FAULT_CODES[f["code"]] == f["name"]
    det = f["detected_tick"] - K0
    assert 0 <= det <= bound
    assert f["passive_tick"] - f["detected_tick"] <= 1
    passive_rows = r.signal("passive")[f["passive_tick"]:]
    assert passive_rows.all()  # latched (default recovery) until the end
    # the tracking follows F_min once the prefilter has settled (1 kHz: well within 100 ticks)
    np.testing.assert_allclose(r.signal("F_set_filtered")[f["passive_tick"] + 100:], cfg.tracking.F_min_N, atol=0.5)
    for n in PLANT_INPUTS:
        assert np.isfinite(r.signal(n)).all(), n
    ratio = response(r, K0, freq, cfg.dt_s) / response(passive(amp, freq), K0, freq, cfg.dt_s)
    with capsys.disabled():
        print(f"\n[supervisor] {spec}: {f['name']} +{det} ticks, response / passive {ratio:.3f}", end="")
    assert ratio <= 1 + MARGIN


@pytest.mark.timing
def test_cpu_stall_is_an_overrun_burst_in_paced_mode(cfg, loops, passive, capsys):
    """60 us of busy delay per tick (> the 47.6 us period): every tick overruns; the burst check
    (overrun_count = 50 within 10 ms) trips on the 50th, one tick after it is known."""
    L = loops("lyapunov", "oracle")
    run(L, 196.0, 5.0, 0.01, paced=True)  # compiled, warm
    r = run(L, 196.0, 5.0, 0.3, paced=True, faults=schedule(["cpu_stall@0.1:0.05"], cfg))
    f = summary(r)["faults"][0]
    assert f["name"] == "overrun_burst" and f["tick"] == 2100
    assert 0 <= f["detected_tick"] - 2100 <= cfg.supervisor.overrun_count + 5
    assert f["passive_tick"] == f["detected_tick"]
    for n in PLANT_INPUTS:
        assert np.isfinite(r.signal(n)).all()
    # the simulated physics does not depend on the wall clock: the same response window offline
    ref = first_harmonic_amplitude(passive(5.0, 196.0).signal("a_frf")[2100:6300], 196.0, cfg.dt_s)
    assert response(r, 2100, 196.0, cfg.dt_s) <= (1 + MARGIN) * ref


# --- recovery, disable, split runs -------------------------------------------------------------

def test_latch_holds_and_auto_recovers_after_the_clean_window(cfg, loops):
    spec = ["sensor_dropout@0.2:0.01"]  # ticks 4200 .. 4409
    latch = run(loops("lyapunov", "observer"), 196.0, 5.0, 0.4, faults=schedule(spec, cfg))
    assert summary(latch)["trips"] == [{"code": 1, "name": "sensor_nonfinite", "tick": 4200, "recovered_tick": None}]
    assert latch.signal("passive")[4200:].all() and (latch.signal("fault_latched")[4200:] == 1).all()
    c_auto = load(sets=["supervisor.recovery=auto", "supervisor.clean_window_s=0.02"])
    auto = run(loops("lyapunov", "observer", c_auto), 196.0, 5.0, 0.4, faults=schedule(spec, c_auto))
    (trip,) = summary(auto)["trips"]
    # clean from tick 4410 (the first finite reading) for 420 ticks: active again at 4410 + 420 - 1
    assert trip["tick"] == 4200 and trip["recovered_tick"] == 4410 + 420 - 1
    p = auto.signal("passive")
    assert p[4200:trip["recovered_tick"]].all() and not p[trip["recovered_tick"]:].any()
    # active again: the law's F_set reaches the tracking again (Lyapunov rises above F_min)
    assert auto.signal("F_set_filtered")[trip["recovered_tick"]:].max() > cfg.tracking.F_min_N + 50


def test_disabled_supervisor_monitors_only(cfg, loops):
    c = load(sets=["supervisor.enable=false"])
    r = run(loops("lyapunov", "observer", c), 196.0, 5.0, 0.3, faults=schedule(["sensor_dropout/F_cell@0.1:0.01"], c))
    code = r.signal("fault_code")
    assert (code[2100:2310] == 1).all() and not r.signal("passive").any()
    for n in PLANT_INPUTS:  # the NaN readings are still held out of the controller
        assert np.isfinite(r.signal(n)).all()


def test_split_run_with_supervisor_state_is_bit_identical(cfg, loops):
    c = load(sets=["supervisor.recovery=auto", "supervisor.clean_window_s=0.01"])
    L = loops("lyapunov", "observer", c)
    f = schedule(["sensor_stuck@0.05:0.02", "sensor_bias/F_cell@0.09:0.01"], c)
    keep = np.setdiff1d(np.arange(len(L.signals)), [L.column("tick_ns"), L.column("late_ns")])
    whole = run(L, 196.0, 5.0, 0.15, faults=f)
    first = run(L, 196.0, 5.0, 0.07, faults=f)  # split while passive, counting clean ticks
    second = run(L, 196.0, 5.0, 0.08, faults=f, start=first.final)
    assert len(summary(whole)["trips"]) == 2  # both detected, both recovered: the state matters
    assert np.array_equal(whole.log[:, keep], np.vstack([first.log, second.log])[:, keep])
    np.testing.assert_array_equal(whole.final.sv, second.final.sv)


# --- CLI and replay ----------------------------------------------------------------------------

def test_simulate_json_faults_and_replay_bit_exact(tmp_path, capsys):
    """An observer-stage fault (replayed from the metadata) and a force-sensor fault (in the
    recorded readings): the replay runs the supervisor and is bit-exact, including its outputs."""
    out = tmp_path / "faulty"
    code = main(["simulate", "--law", "lyapunov", "--estimator", "observer", "--freq", "196", "--amp", "5",
                 "--duration", "0.3", "--fault", "observer_mismatch@0.1:0.002", "--fault", "sensor_bias/F_cell@0.2",
                 "--out", str(out), "--no-rrd", "--json"])
    s = json.loads(capsys.readouterr().out)
    assert code == 0
    (a, b) = s["faults"]
    assert (a["kind"], a["tick"], a["name"]) == ("observer_mismatch", 2100, "observer_divergence")
    assert a["code"] == FAULT_CODES.index("observer_divergence") and a["passive_tick"] == a["detected_tick"] <= 2105
    assert b["kind"] == "sensor_bias" and b["sensor"] == "F_cell" and b["tick"] == 4200
    code = main(["replay", str(out) + ".mcap", "--json"])
    r = json.loads(capsys.readouterr().out)
    assert code == 0 and r["bit_exact"] is True
    assert {"fault_code", "fault_latched", "passive"} <= set(r["signals_compared"])
    assert r["outputs"]["passive"]["max"] == 1.0  # not vacuous: the replayed supervisor tripped too


@pytest.mark.parametrize("fault, words", [
    ("bogus@0.1", ["'bogus@0.1'", "unknown kind", "sensor_dropout"]),
    ("sensor_stuck", ["'sensor_stuck'", "KIND[/SENSOR][=VALUE]@TIME[:DURATION]"]),
    ("sensor_bias/a_mid@0.1", ["a_mid", "a_tip, a_frf, F_strain, F_cell"]),
    ("actuator_loss/a_tip@0.1", ["only the sensor kinds", "drop /a_tip"]),
    ("sensor_gain=x@0.1", ["must be numbers"]),
    ("sensor_dropout@0.1:-1", ["DURATION", "> 0 s"]),
    ("sensor_dropout@5", ["starts after the run's end"]),
    ("cpu_stall@0.1", ["--paced"]),
])
def test_bad_fault_strings_exit_2_with_one_line(fault, words, capsys):
    code = main(["simulate", "--freq", "196", "--amp", "5", "--duration", "0.1", "--fault", fault])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and all(w in err[0] for w in words), err
