"""The closed loop: timing budget, determinism, bad input, and the laws' first physics figures."""
import json

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.common.config import load
from frictionrt.rt.loop import COMPONENTS, build_loop, run, summary
from frictionrt.rt.log.mcap_log import read_mcap
from frictionrt.rt.log.writer import BLOCK_TICKS

BUDGET_US = 1e6 / 21000
F3, AMP = 223.6, 5.0  # an excitation near mode 3 and a moderate force (the physics tests place their own)


@pytest.fixture(scope="module")
def loops():
    cfg = load()
    return {law: build_loop(cfg, law) for law in ("passive", "hysteresis", "lyapunov")}


@pytest.mark.timing
def test_timing_budget_per_component_and_tick(loops):
    # robust on a shared 2-core machine: the median tick far below the budget (a quarter),
    # its p99 below the budget; the plant's median below a fifth (the converged joint's 17
    # contact points: issue 31's target for the whole tick is 8 us, which `python -m
    # benchmarks.budget_ab` measures), every other component's below a tenth. The machine's
    # speed is bimodal (docs/plant.md 6.4: the plant's median 3.8..4.8 or 5.4..6.9 us from one
    # `budget` run to the next; `bench plant` once 7.8 us on an idle machine), so the better of
    # two 1 s runs is judged. The tight figures are the benchmarks', not asserted here.
    r = min((run(loops["lyapunov"], F3, AMP, 1.0, timing=True) for _ in range(2)),
            key=lambda r: np.median(r.signal("tick_ns")))
    tick_us = r.signal("tick_ns") / 1e3
    assert np.median(tick_us) < BUDGET_US / 4
    assert np.percentile(tick_us, 99) < BUDGET_US
    med = np.median(r.comp_ns, axis=0) / 1e3
    for name, m in zip(COMPONENTS, med):
        assert m < BUDGET_US / (5 if name == "plant" else 10), f"{name}: median {m:.2f} us"


def test_same_seed_bit_identical_other_seed_changes_noise(loops):
    L = loops["hysteresis"]
    timing_cols = [L.column("tick_ns"), L.column("late_ns")]  # wall-clock, not signals
    keep = np.setdiff1d(np.arange(len(L.signals)), timing_cols)
    a = run(L, F3, AMP, 0.2, seed=7).log[:, keep]
    b = run(L, F3, AMP, 0.2, seed=7).log[:, keep]
    c = run(L, F3, AMP, 0.2, seed=8)
    assert np.array_equal(a, b)
    # another seed: the noisy readings differ, the structure's response hardly
    i_meas = list(keep).index(L.column("a_frf_meas"))
    assert not np.array_equal(a[:, i_meas], c.log[:, L.column("a_frf_meas")])
    s_a = summary(run(L, F3, AMP, 0.2, seed=7))
    assert summary(c)["acc045_amplitude"] == pytest.approx(s_a["acc045_amplitude"], rel=0.02)


def test_run_continued_from_its_final_state_equals_one_run(loops):
    # the step-sine FRF continues from the previous point's state: a run split in two at the
    # same frequency must be the same run, bit for bit (all states incl. noise and the plant's
    # contact-solver cache carry over; ticks continue)
    L = loops["lyapunov"]
    keep = np.setdiff1d(np.arange(len(L.signals)), [L.column("tick_ns"), L.column("late_ns")])
    whole = run(L, F3, AMP, 0.1)
    first = run(L, F3, AMP, 0.04)
    second = run(L, F3, AMP, 0.06, start=first.final)
    assert first.final.k == 840 and second.final.k == 2100
    assert np.array_equal(whole.log[:, keep], np.vstack([first.log, second.log])[:, keep])
    third = run(L, F3, AMP, 0.01, start=first.final)  # the start is not consumed
    assert np.array_equal(third.log[:, keep], second.log[:210, keep])


@pytest.mark.parametrize("freq, amp, dur, match", [
    (11000.0, 5.0, 0.1, "Nyquist"),
    (200.0, -1.0, 0.1, "--amp"),
    (200.0, 5.0, 1e6, "GiB"),
    (200.0, 5.0, 0.0, "--duration"),
])
def test_bad_run_input_is_refused_before_the_loop(loops, freq, amp, dur, match):
    with pytest.raises(ValueError, match=match):
        run(loops["passive"], freq, amp, dur)


def test_unstable_force_tracking_design_is_refused():
    with pytest.raises(ValueError, match="pid_bandwidth_hz"):
        build_loop(load(sets=["tracking.pid_bandwidth_hz=8000"]), "lyapunov")


def test_laws_reduce_the_mode3_peak_at_5N(loops, capsys):
    """Oracle estimator, 5 N, the mode-3 resonance region (from 12 Hz below to 3 Hz above the
    model's passive mode-3 resonance, plant.modes.passive_resonance_hz: 193..208 Hz, 1.5 s per
    point): both laws lower the peak of the 0.45 m acceleration against passive F_N1 = 40 N and
    Lyapunov more than hysteresis-optimal (SPEC claims C3, C5); Lyapunov uses far more actuator
    energy (C6). Measured: peaks 32.3 / 23.8 / 15.6 m/s^2 (passive / hysteresis / Lyapunov), i.e.
    -27 % and -52 %, energy 0.55 J against 7.6 mJ. The margins below are what the model must
    keep, not the figures."""
    from frictionrt.plant.modes import passive_resonance_hz
    f3 = passive_resonance_hz(next(iter(loops.values())).cfg, 3)
    freqs = np.arange(f3 - 12.0, f3 + 3.5, 3.0)
    peak, energy = {}, {}
    for law, L in loops.items():
        s = [summary(run(L, f, AMP, 1.5)) for f in freqs]
        peak[law] = max(v["acc045_amplitude"] for v in s)
        energy[law] = max(v["actuator_energy_j"] for v in s)
    with capsys.disabled():
        print("\n[loop] mode-3 peak at 5 N: " + ", ".join(f"{law} {p:.2f} m/s^2" for law, p in peak.items()), end="")
    assert peak["hysteresis"] < peak["passive"]
    assert peak["lyapunov"] < 0.7 * peak["passive"]
    assert peak["lyapunov"] < peak["hysteresis"]
    assert energy["lyapunov"] > 10 * energy["hysteresis"]


def test_simulate_cli_json_and_log(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["simulate", "--law", "lyapunov", "--freq", "223.6", "--amp", "5", "--duration", "0.1",
                 "--out", str(out), "--json"])
    s = json.loads(capsys.readouterr().out)
    assert code == 0
    for key in ("acc045_amplitude", "fn1_mean_n", "actuator_energy_j", "ticks", "overruns"):
        assert key in s
    assert s["ticks"] == 2100
    data = read_mcap(str(out) + ".mcap")
    assert data.log.shape == (2100, len(data.signals)) and "plant.interface" in data.metadata["config"]


@pytest.mark.parametrize("args, words", [
    (["simulate", "--freq", "20000", "--amp", "5"], ["--freq", "Nyquist"]),
    (["simulate", "--freq", "200", "--amp", "-5"], ["--amp"]),
    (["--set", "observer.alpha_s_m=8000", "simulate", "--freq", "200", "--amp", "5", "--estimator", "observer"],
     ["observer", "fric_noise_N", "alpha_s_m", "unstable"]),
    (["--set", "tracking.pid_bandwidth_hz=8000", "simulate", "--law", "lyapunov", "--freq", "200", "--amp", "5"],
     ["pid_bandwidth_hz"]),
])
def test_simulate_bad_input_exit_2(args, words, capsys):
    code = main(args)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and all(w in err[0] for w in words)


def test_compare_cli_table_and_plot(tmp_path, capsys):
    png = tmp_path / "laws.png"
    code = main(["compare", "--duration", "0.2", "-o", str(png), "--json"])
    rows = json.loads(capsys.readouterr().out)
    assert code == 0 and [r["law"] for r in rows] == ["passive", "hysteresis", "lyapunov"]
    assert rows[0]["change_pct"] == 0.0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_compare_refuses_a_zero_force_in_one_line(capsys):
    # its table is relative to the passive response, which 0 N leaves at 0 (it printed +4e9 %)
    assert main(["compare", "--amp", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--amp 0 N" in err[0] and "> 0 N" in err[0]


def test_compare_places_the_laws_at_the_passive_step_sine_peak():
    """compare --mode finds the passive resonance by step-sine (passive_peak_hz), not at the linear
    picture of the sliding joint 1.8 % above it. Measured at 5 N, mode 3: |H| 6.64 at 201.64 Hz,
    6.52 / 5.05 at -/+1 %, 3.87 at the linear 205.2 Hz; there the hysteresis law came out 6.5 %
    above passive, at the peak it is 31 % below and Lyapunov 56 % (docs/loop.md)."""
    from frictionrt.plant.modes import passive_resonance_hz
    from frictionrt.rt.experiments.compare import compare, passive_peak_hz, table
    from frictionrt.rt.experiments.reproduce import QUICK
    from frictionrt.rt.experiments.stepsine import sweep
    cfg = load()
    passive = build_loop(cfg, "passive")
    f = passive_peak_hz(passive, 3, AMP)
    H = {x: sweep(passive, [x], AMP, settle=QUICK.settle).H_abs[0]
         for x in (0.99 * f, f, 1.01 * f, passive_resonance_hz(cfg, 3))}
    h_minus, h_peak, h_plus, h_linear = H.values()
    assert h_peak > 0.95 * max(h_minus, h_plus)   # the top, to the refinement's resolution
    assert h_peak > 1.1 * h_linear   # measured 6.81 against 5.67 on the 10 mm plant (6.64 / 3.87 on the 20 mm one)
    rows = table(compare(cfg, f, AMP, 1.0))
    assert -15 > rows[1]["change_pct"] > rows[2]["change_pct"]   # negative: lower than passive


def test_bench_loop_against_python_control(capsys):
    # python-control's nlsys + input_output_response drives the same discrete controller part
    # (same step functions): identical V_cmd, and the compiled loop must be much faster
    code = main(["bench", "loop", "--json", "--steps", "2000"])
    r = json.loads(capsys.readouterr().out)
    assert code == 0
    for key in ("median_us", "p99_us", "p999_us", "max_us"):
        assert r["total"][key] > 0
    assert r["max_abs_diff_v"] == 0.0
    assert r["speedup"] > 10


def test_paced_run_interrupted_keeps_its_log(tmp_path):
    """Ctrl-C (SIGINT) during a paced run: the loop stops within a tick, the ticks run so far
    are summarised and saved (exit code 130), nothing is lost or half written."""
    import signal

    from tests.cli_process import start_cli, wait_for_chunks
    out = tmp_path / "paced"
    proc = start_cli("simulate", "--paced", "--freq", 200, "--amp", 5, "--duration", 30, "--out", out, "--json")
    wait_for_chunks(proc, tmp_path / "paced.mcap.part", 3)  # the loop runs, however long start-up took
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    s = json.loads(stdout)
    assert s["interrupted"] and 0 < s["ticks"] < 30 * 21000
    data = read_mcap(str(out) + ".mcap")  # finalised and indexed; paced: whole blocks may be dropped
    assert data.log.shape[0] == s["ticks"] - BLOCK_TICKS * s["dropped_blocks"] and np.all(np.isfinite(data.log))
    assert data.k[-1] == s["ticks"] - 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["paced.foxglove.json", "paced.mcap", "paced.rrd"]  # no .part left
