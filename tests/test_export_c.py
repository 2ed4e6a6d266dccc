"""The controller as C (rt/export, frictionrt export-c, replay --c; docs/export-c.md): every law with
both estimators replays bit for bit through the exported C, at -O0 and -O2, with gcc's strict
warnings as errors (and clang's when installed), fault-injection logs with the supervisor's
passive fallback included; the Makefile's harness under AddressSanitizer and UBSan reproduces a
log; the object calls no library function and has no mutable globals; unsafe floating-point
builds are refused; bad input exits 2 in one line. Logs of 0.05 s (1050 ticks) keep it short."""
import json
import os
import re
import shutil
import subprocess

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.export.cbuild import OUTPUTS
from frictionrt.rt.export.replay_c import READINGS, replay_c
from frictionrt.rt.log.mcap_log import read_mcap

LAWS = ("passive", "hysteresis", "lyapunov")
ESTIMATORS = ("oracle", "observer")
TICKS = 1050


def simulate(path, law, estimator, sets=(), faults=(), duration="0.05"):
    code = main([*sets, "simulate", "--law", law, "--estimator", estimator, "--freq", "223.6", "--amp", "5",
                 "--duration", duration, "--out", str(path), "--no-rrd", "--json",
                 *(x for f in faults for x in ("--fault", f))])
    assert code == 0
    return path.with_name(path.name + ".mcap")


def run(capsys, *args):
    code = main([*map(str, args), "--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out.splitlines()[-1]) if out.out.strip() else None), out.err


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A 0.05 s log and an export from the configuration for each law and estimator."""
    d = tmp_path_factory.mktemp("export_c")
    out = {}
    for law in LAWS:
        for est in ESTIMATORS:
            log = simulate(d / f"{law}_{est}", law, est)
            exp = d / f"c_{law}_{est}"
            assert main(["export-c", "--law", law, "--estimator", est, "-o", str(exp), "--json"]) == 0
            out[law, est] = (log, exp)
    return out


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("estimator", ESTIMATORS)
def test_every_law_and_estimator_replays_bit_exact_through_the_c(runs, capsys, law, estimator):
    log, exp = runs[law, estimator]
    capsys.readouterr()
    code, r, err = run(capsys, "replay", log, "--c", exp)
    assert code == 0, err
    assert r["bit_exact"] is True and r["ticks"] == TICKS and r["first_mismatch_tick"] is None
    assert r["signals_compared"] == list(OUTPUTS) and len(OUTPUTS) == 13
    assert (r["law"], r["estimator"]) == (law, estimator)
    assert r["design_hash"] == json.loads((exp / "frictionrt_export.json").read_text())["design_hash"]
    assert r["log_design_hash"] == r["design_hash"] == read_mcap(log).metadata["controller_design"]
    assert "-std=c99 -O2 -ffp-contract=off" in r["build"]
    rec = read_mcap(log)   # not vacuous: the controller commanded something
    v = rec.log[:, rec.column("V_cmd")]
    assert v.max() > v.min() or law == "passive"


@pytest.mark.parametrize("opt, law, estimator", [("-O0", "hysteresis", "oracle"), ("-O0", "lyapunov", "observer"),
                                                 ("-O2", "lyapunov", "observer")])
def test_gcc_at_O0_and_O2_with_strict_warnings_as_errors_is_bit_exact(runs, opt, law, estimator):
    log, exp = runs[law, estimator]
    r, _ = replay_c(log, exp, cc="gcc", opt=opt, extra=("-Werror",))
    assert r["bit_exact"] is True and r["ticks"] == TICKS
    assert f"gcc -std=c99 {opt} -ffp-contract=off -Wall -Wextra -pedantic -Werror" in r["build"]


@pytest.mark.skipif(shutil.which("clang") is None, reason="clang not installed (apt-get install clang)")
@pytest.mark.parametrize("law, estimator, opts", [("passive", "oracle", ("-O2",)), ("lyapunov", "observer", ("-O0", "-O2"))])
def test_clang_with_strict_warnings_as_errors_is_bit_exact(runs, law, estimator, opts):
    log, exp = runs[law, estimator]
    for opt in opts:
        r, _ = replay_c(log, exp, cc="clang", opt=opt, extra=("-Werror",))
        assert r["bit_exact"] is True and r["ticks"] == TICKS


@pytest.mark.parametrize("law, estimator, sets, faults, codes", [
    ("lyapunov", "observer", ["--set", "supervisor.recovery=auto"],
     ["observer_mismatch=50@0.01:0.005", "sensor_dropout/F_cell@0.03:0.002", "sensor_stuck/a_frf@0.035:0.01"],
     {1, 3, 5}),
    ("hysteresis", "oracle", [], ["sensor_dropout@0.01:0.003", "sensor_bias/F_strain@0.03:0.005",
                                  "actuator_loss@0.04:0.003"], {1, 4, 8})])
def test_fault_injection_logs_replay_bit_exact_with_the_passive_fallback(tmp_path, capsys, law, estimator, sets,
                                                                        faults, codes):
    log = simulate(tmp_path / "faults", law, estimator, sets, faults, duration="0.06")
    capsys.readouterr()
    assert main([*sets, "export-c", "--from-log", str(log), "-o", str(tmp_path / "c"), "--json"]) == 0
    r, out = replay_c(log, tmp_path / "c")
    assert r["bit_exact"] is True and r["ticks"] == 1260
    code, rn, err = run(capsys, *sets, "replay", log)   # the numba replay takes the logged dropouts too
    assert code == 0 and rn["bit_exact"] is True and rn["ticks"] == 1260, err
    rec = read_mcap(log)
    assert np.isnan(rec.log[:, [rec.column(c) for c in READINGS]]).any()   # dropouts fed as logged
    assert codes <= set(out[:, OUTPUTS.index("fault_code")].astype(int)) and out[:, OUTPUTS.index("passive")].any()


def test_the_makefile_harness_under_address_and_ub_sanitizers_reproduces_a_log(runs, tmp_path):
    log, exp = runs["lyapunov", "observer"]
    work = tmp_path / "c"
    shutil.copytree(exp, work)
    flags = "-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -Werror"
    subprocess.run(["make", "-C", str(work), "OPT=-O1", f"EXTRA={flags}"], check=True, capture_output=True)
    rec = read_mcap(log)
    rows = rec.log[:, [rec.column(c) for c in READINGS]]
    text = "".join(f"{k} {' '.join(v.hex() for v in row)} 0\n" for k, row in zip(rec.k, rows))
    p = subprocess.run([str(work / "ctrl_harness")], input=text, capture_output=True, text=True,
                       env={**os.environ, "ASAN_OPTIONS": "detect_leaks=0"})
    assert p.returncode == 0 and p.stderr == "", p.stderr[-2000:]
    lines = [ln.split() for ln in p.stdout.splitlines() if not ln.startswith("#")]
    got = np.array([[float.fromhex(x) for x in ln[1:]] for ln in lines])
    ref = rec.log[:, [rec.column(c) for c in OUTPUTS]]
    assert got.shape == (TICKS, 13) and (got.view(np.uint64) == ref.view(np.uint64)).all()


def test_the_object_calls_no_library_function_and_has_no_mutable_globals(runs, tmp_path):
    for est in ESTIMATORS:
        exp = runs["lyapunov", est][1]
        obj = tmp_path / f"{est}.o"
        subprocess.run(["cc", "-std=c99", "-O2", "-ffp-contract=off", "-c", "-o", str(obj),
                        str(exp / "frictionrt_ctrl.c")], check=True)
        assert subprocess.run(["nm", "-u", str(obj)], capture_output=True, text=True).stdout.strip() == ""
        text, data, bss = map(int, subprocess.run(["size", str(obj)], capture_output=True, text=True)
                              .stdout.splitlines()[1].split()[:3])
        assert text > 0 and data == 0 and bss == 0
        src = re.sub(r"/\*.*?\*/", "", (exp / "frictionrt_ctrl.c").read_text(), flags=re.S)   # code, no comments
        assert not re.search(r"\b(malloc|calloc|realloc|free|fmin|fmax|atan|atan2)\s*\(", src)


@pytest.mark.parametrize("flag, message", [("-mfpmath=387", "FLT_EVAL_METHOD"), ("-ffast-math", "fast-math")])
def test_unsafe_floating_point_builds_are_refused(runs, tmp_path, flag, message):
    exp = runs["lyapunov", "observer"][1]
    p = subprocess.run(["gcc", "-std=c99", flag, "-c", "-o", str(tmp_path / "x.o"), str(exp / "frictionrt_ctrl.c")],
                       capture_output=True, text=True)
    assert p.returncode != 0 and message in p.stderr


def test_bad_input_exits_2_in_one_line(runs, capsys, tmp_path):
    log, _ = runs["lyapunov", "observer"]
    other = runs["passive", "observer"][1]
    (tmp_path / "empty").mkdir()
    cases = [(tmp_path / "empty", "not a frictionrt C export"),
             (tmp_path / "missing", "no such folder"),
             (other, "an export of another design (sha256:")]
    for folder, problem in cases:
        code, r, err = run(capsys, "replay", log, "--c", folder)
        assert code == 2 and problem in err and len(err.strip().splitlines()) == 1, err
    code, r, err = run(capsys, "replay", log, "--c", runs["lyapunov", "observer"][1], "--cc", "no-such-cc")
    assert code == 2 and "no C compiler 'no-such-cc' found" in err and len(err.strip().splitlines()) == 1
    code, r, err = run(capsys, "export-c", "-o", runs["lyapunov", "observer"][1], "--law", "lyapunov")
    assert code == 2 and "pass --force" in err


def test_the_design_hash_is_the_logs_and_changes_with_a_controller_parameter(runs, capsys, tmp_path):
    log, exp = runs["lyapunov", "observer"]
    ref = json.loads((exp / "frictionrt_export.json").read_text())["design_hash"]
    capsys.readouterr()
    code, m, _ = run(capsys, "export-c", "--from-log", log, "-o", tmp_path / "from_log")
    assert code == 0 and m["design_hash"] == ref and m["law"] == "lyapunov"
    assert ref in (tmp_path / "from_log" / "ctrl_config.h").read_text()
    code, m, _ = run(capsys, "--set", "tracking.F_max_N=550", "export-c", "--law", "lyapunov", "--estimator",
                     "observer", "-o", tmp_path / "changed")
    assert code == 0 and m["design_hash"] != ref


def test_bench_controller_times_numba_and_the_c_on_the_same_readings(runs, capsys, tmp_path):
    exp = runs["lyapunov", "observer"][1]
    capsys.readouterr()
    code, r, err = run(capsys, "bench", "controller", "--steps", "1000", "--c", exp)
    assert code == 0, err
    assert (r["law"], r["estimator"], r["ticks"]) == ("lyapunov", "observer", 1000)
    for part in ("numba", "c"):
        assert 0 < r[part]["median_us"] <= r[part]["p99_us"] <= r[part]["p999_us"] <= r[part]["max_us"]
    c = r["c"]
    assert c["outputs_identical"] is True and c["state_bytes"] == 912
    assert c["size"]["text"] > 0 and c["size"]["data"] == 0 and c["size"]["bss"] == 0
    code, r, err = run(capsys, "bench", "controller", "--steps", "1000", "--law", "passive", "--c", exp)
    assert code == 2 and "an export of another design" in err


def test_overruns_of_a_paced_log_give_the_c_the_numba_replays_outputs(runs, tmp_path):
    """The supervisor's overrun check (a burst of 60 overrunning ticks: overrun_burst), which only
    paced runs reach: a log marked paced with long tick_ns, replayed through numba and the C."""
    from frictionrt.rt.log.writer import McapBlockWriter
    from frictionrt.rt.loop.replay import replay_outputs
    log, exp = runs["lyapunov", "observer"]
    rec = read_mcap(log)
    data = rec.log.copy()
    data[300:360, rec.column("tick_ns")] = 1e6   # 1 ms: each of these ticks overran
    path = tmp_path / "paced.mcap"
    with McapBlockWriter(path, rec.signals, rec.rate_hz, dict(rec.metadata, paced="true")) as w:
        w.write_block(0, data)
    _, _, ref = replay_outputs(path)
    r, out = replay_c(path, exp)
    assert (out[:, 1:].view(np.uint64) == ref.view(np.uint64)).all()
    assert 9 in set(out[:, OUTPUTS.index("fault_code")].astype(int))   # overrun_burst
    assert r["bit_exact"] is False and r["first_mismatch_tick"] is not None   # the record had no overruns


@pytest.mark.parametrize("law, estimator", [("hysteresis", "oracle"), ("lyapunov", "observer")])
def test_the_loop_with_the_c_controller_writes_the_numba_loops_log(runs, law, estimator):
    """Software in the loop (rt/export/sil.py): the C export called from the compiled loop through a
    ctypes function argument gives the simulate log's every signal bit for bit (timing columns aside)."""
    from frictionrt.rt.common.config import load
    from frictionrt.rt.export.sil import run_sil
    from frictionrt.rt.loop import build_loop
    log, exp = runs[law, estimator]
    rec = read_mcap(log)
    loop = build_loop(load(), law, estimator)
    got = run_sil(loop, exp, 223.6, 5.0, 0.05)
    names = [n for n, _, _ in loop.signals if n not in ("tick_ns", "late_ns")]
    assert got.shape == (TICKS, len(loop.signals)) and len(names) == 144   # 52 + 4 per contact point (23)
    a = got[:, [loop.column(n) for n in names]]
    b = rec.log[:, [rec.column(n) for n in names]]
    assert (a.view(np.uint64) == b.view(np.uint64)).all()


WALL_CLOCK = ("tick_median_us", "tick_max_us", "wall_s")   # summary figures of the wall clock


@pytest.mark.parametrize("law, estimator", [("hysteresis", "oracle"), ("lyapunov", "observer")])
def test_a_c_controller_run_ends_in_the_numba_runs_state(runs, law, estimator):
    """After a run with the C controller, the run's final state (every controller state among
    them: estimator, RT1, prefilter, PID, supervisor, the law's and the tracking's last outputs)
    and the summary simulate prints equal the numba run's, so a run continued from it is the
    same whichever controller ran before: C then numba, numba then C and C then C each equal one
    numba run (0.05 s, split at 0.025 s)."""
    from frictionrt.rt.common.config import load
    from frictionrt.rt.export.sil import CController
    from frictionrt.rt.loop import build_loop, run as run_loop, summary
    loop = build_loop(load(), law, estimator)
    c = CController(loop, runs[law, estimator][1], loop.cfg.rt.seed)
    ref, sil = run_loop(loop, 223.6, 5.0, 0.05), run_loop(loop, 223.6, 5.0, 0.05, controller=c)
    for name, a in vars(ref.final).items():
        b = getattr(sil.final, name)
        pairs = zip(a, b) if name == "plant_work" else [(a, b)]
        assert all(np.asarray(x).dtype == np.asarray(y).dtype and np.asarray(x).tobytes() == np.asarray(y).tobytes()
                   for x, y in pairs), name   # bit for bit
    s_ref, s_sil = summary(ref), summary(sil)
    assert {k: v for k, v in s_ref.items() if k not in WALL_CLOCK} == \
        {k: v for k, v in s_sil.items() if k not in WALL_CLOCK}
    keep = [i for i, (n, _, _) in enumerate(loop.signals) if n not in ("tick_ns", "late_ns")]
    for first, second in ((c, None), (None, c), (c, c)):
        a = run_loop(loop, 223.6, 5.0, 0.025, controller=first)
        b = run_loop(loop, 223.6, 5.0, 0.025, start=a.final, controller=second)
        both = np.vstack([a.log, b.log])[:, keep]
        assert (both.view(np.uint64) == ref.log[:, keep].view(np.uint64)).all(), (first, second)


def test_simulate_with_the_c_controller_logs_the_numba_runs_bits(runs, capsys, tmp_path):
    """simulate --controller c:DIR --out: the MCAP log equals the numba run's (timing aside) and
    replays bit-exact; bad --controller values exit 2 in one line."""
    log, exp = runs["lyapunov", "observer"]
    sil = tmp_path / "sil.mcap"
    assert main(["simulate", "--law", "lyapunov", "--estimator", "observer", "--freq", "223.6", "--amp", "5",
                 "--duration", "0.05", "--out", str(tmp_path / "sil"), "--no-rrd", "--json",
                 "--controller", f"c:{exp}"]) == 0
    a, b = read_mcap(sil), read_mcap(log)
    names = [n for n, _, _ in b.signals if n not in ("tick_ns", "late_ns")]
    assert len(names) == 144   # 52 + 4 per contact point (23)
    assert (a.log[:, [a.column(n) for n in names]].view(np.uint64)
            == b.log[:, [b.column(n) for n in names]].view(np.uint64)).all()
    capsys.readouterr()
    code, r, err = run(capsys, "replay", sil)
    assert code == 0 and r["bit_exact"] is True, err
    for spec, problem in ((f"c:{tmp_path}", "not a frictionrt C export"), ("fortran:x", "give c:DIR"),
                          (f"c:{runs['passive', 'observer'][1]}", "an export of another design")):
        code, _, err = run(capsys, "simulate", "--law", "lyapunov", "--estimator", "observer", "--freq", "223.6",
                           "--amp", "5", "--duration", "0.01", "--controller", spec)
        assert code == 2 and problem in err and len(err.strip().splitlines()) == 1, err


def test_a_paced_run_with_the_c_controller_replays_bit_exact(runs, capsys, tmp_path):
    """A paced run with the C controller (run(..., paced=True, controller=)), logged by the run's
    writer while it runs: the deadlines and the overrun flags reach the C's supervisor as the numba
    replay rebuilds them from tick_ns + late_ns. The run is as long as the writer's ring (0.1 s, one
    block), the case in which the paced writer used to drop the only block (rt/log/writer.py
    ``_overwritten``; forced deterministically in tests/test_logging_loop.py)."""
    from frictionrt.rt.common.config import load
    from frictionrt.rt.export.sil import CController
    from frictionrt.rt.log.writer import open_run_log, run_metadata
    from frictionrt.rt.loop import build_loop, run as run_loop
    cfg = load()
    loop = build_loop(cfg, "lyapunov", "observer")
    meta = run_metadata(cfg, "lyapunov", "observer", cfg.rt.seed, 223.6, 5.0, 0.1, True) | {"faults": "[]"}
    w = open_run_log(tmp_path / "paced", loop.signals, 1.0 / cfg.dt_s, meta, rrd=False, ring_s=0.1)
    r = run_loop(loop, 223.6, 5.0, 0.1, paced=True, writer=w,
                 controller=CController(loop, runs["lyapunov", "observer"][1], cfg.rt.seed))
    assert r.ticks == w.ring_ticks == 2 * TICKS and w.dropped_blocks == 0
    code, rr, err = run(capsys, "replay", tmp_path / "paced.mcap")
    assert code == 0 and rr["bit_exact"] is True and rr["ticks"] == 2 * TICKS, err


def test_frf_with_a_c_export_gives_the_numba_controllers_sweep(runs, capsys):
    """frf --controller c:DIR: the law it was exported for runs the C and each point (one here, of
    6 blocks, 0.12 s) equals the numba sweep's; an export of a law the sweep does not run exits 2
    in one line. (compare's test has a numba law beside the C one.)"""
    exp = runs["lyapunov", "observer"][1]   # frf's default estimator
    args = ("frf", "--law", "lyapunov", "--amp", "5", "--freqs", "1000", "--max-time", "0.13", "--jobs", "1")
    code, ref, err = run(capsys, *args)
    assert code == 0, err
    code, got, err = run(capsys, *args, "--controller", f"c:{exp}")
    assert code == 0, err
    assert ref["controllers"] == {"lyapunov": "numba"} and got["controllers"] == {"lyapunov": f"c:{exp}"}
    assert got["results"] == ref["results"] and len(ref["results"]) == 1
    assert ref["results"][0]["n_blocks"] == [6]
    code, _, err = run(capsys, *args, "--controller", f"c:{runs['lyapunov', 'oracle'][1]}")
    assert code == 2 and "an export of another design" in err and len(err.strip().splitlines()) == 1, err


def test_compare_with_a_c_export_gives_the_numba_controllers_table(runs, capsys):
    """compare --controller c:DIR (an observer export: compare's default estimator): its law's row
    comes from the C and equals the numba row; two exports for one law exit 2 in one line."""
    exp = runs["hysteresis", "observer"][1]
    args = ("compare", "--freq", "223.6", "--amp", "5", "--duration", "0.05")
    code, ref, err = run(capsys, *args)
    assert code == 0, err
    code, got, err = run(capsys, *args, "--controller", f"c:{exp}")
    assert code == 0, err
    assert [r["controller"] for r in got] == ["numba", f"c:{exp}", "numba"]
    assert [r | {"controller": "numba"} for r in got] == ref
    code, _, err = run(capsys, *args, "--controller", f"c:{exp}", "--controller", f"c:{exp}")
    assert code == 2 and "a second export" in err and len(err.strip().splitlines()) == 1, err


def test_a_c_controller_pickles_and_its_copy_loads_the_library_by_path(runs, tmp_path):
    """What a worker process of frf gets (ctypes objects do not pickle): a copy that loads the
    library the original built, by its path, or builds the export again where that path does not
    exist; each runs as the original."""
    import pickle
    from frictionrt.rt.common.config import load
    from frictionrt.rt.export.sil import CController
    from frictionrt.rt.loop import build_loop, run as run_loop
    loop = build_loop(load(), "lyapunov", "observer")
    c = CController(loop, runs["lyapunov", "observer"][1], loop.cfg.rt.seed)
    copy = pickle.loads(pickle.dumps(c))
    assert copy.build.path == c.build.path and copy.build.path.is_file()
    state = c.__getstate__() | {"library": str(tmp_path / "elsewhere.so")}
    rebuilt = CController.__new__(CController)
    rebuilt.__setstate__(state)
    assert rebuilt.build.path != c.build.path and rebuilt.design_hash == c.design_hash
    keep = [i for i, (n, _, _) in enumerate(loop.signals) if n not in ("tick_ns", "late_ns")]
    ref = run_loop(loop, 223.6, 5.0, 0.02, controller=c).log[:, keep]
    for other in (copy, rebuilt):
        assert (run_loop(loop, 223.6, 5.0, 0.02, controller=other).log[:, keep].view(np.uint64)
                == ref.view(np.uint64)).all()


# ---- golden vectors, make check, the guards ------------------------------------------------------

def _make_check(folder, tmp_path, name, **vars_):
    """make check in a copy of the export folder; (make's exit code: 0, or 2 when ctrl_check failed,
    ctrl_check's ok/FAIL line)."""
    work = tmp_path / name
    shutil.copytree(folder, work)
    p = subprocess.run(["make", "-s", "-C", str(work), "check", *(f"{k}={v}" for k, v in vars_.items())],
                       capture_output=True, text=True)
    lines = [ln for ln in (p.stdout + p.stderr).splitlines() if ln.startswith(("ok:", "FAIL"))]
    return p.returncode, (lines[-1] if lines else p.stdout + p.stderr)


@pytest.mark.parametrize("law, estimator", [("lyapunov", "observer"), ("hysteresis", "oracle")])
def test_every_export_carries_golden_vectors_that_make_check_passes(runs, tmp_path, law, estimator):
    exp = runs[law, estimator][1]
    m = json.loads((exp / "frictionrt_export.json").read_text())
    g = m["golden"]
    # the stream engages the law above F_min, the supervisor's fallback (a dropout: code 1, a range
    # fault: code 2) and the force tracking's saturation
    from frictionrt.rt.loop.coverage import FAULT_NAMES
    assert g["ticks"] == 3150 and g["law_between"] > 100 and g["passive_ticks"] > 100
    assert g["saturated_high"] + g["saturated_low"] > 0
    assert {FAULT_NAMES[1], FAULT_NAMES[2]} <= set(g["fault_codes"])
    assert f"0x{m['param_checksum']}ULL" in (exp / "ctrl_config.h").read_text()
    first = (exp / "golden_in.txt").read_text().splitlines()[0]
    assert first == f"# frictionrt golden {m['design_hash']}"
    compilers = ["cc"] + (["clang"] if shutil.which("clang") else [])
    for cc in compilers:
        code, line = _make_check(exp, tmp_path, cc, CC=cc, EXTRA="-Werror")
        assert code == 0 and line.startswith("ok: 3150 ticks x 13 outputs bit-exact"), (cc, line)


def test_an_edited_parameter_fails_make_check_and_the_libraries_guard(runs, tmp_path):
    from frictionrt.rt.export.cbuild import build
    exp = runs["hysteresis", "observer"][1]
    work = tmp_path / "edited"
    shutil.copytree(exp, work)
    h = work / "ctrl_design.h"
    text = h.read_text()
    k_f = re.search(r"\.K_f = (0x[0-9a-f.p+-]+),", text).group(1)
    one_ulp_up = float(np.nextafter(float.fromhex(k_f), np.inf)).hex()
    h.write_text(text.replace(f".K_f = {k_f},", f".K_f = {one_ulp_up},"))
    code, line = _make_check(work, tmp_path, "edited_check")
    assert code == 2 and line == "FAIL ctrl_init: the parameters differ from the design (ctrl_design.h edited: export again)"
    with pytest.raises(ValueError, match="fails ctrl_init's guard 6: the parameters differ"):
        build(work)


def _has_fma() -> bool:
    try:
        return " fma " in open("/proc/cpuinfo").read().replace("\n", " ")
    except OSError:
        return False


@pytest.mark.parametrize("flags, message", [
    ("-ffp-contract=fast -mfma", "the build fuses multiply-adds"),
    ("-funsafe-math-optimizations", "the build reassociates additions"),
    ("-freciprocal-math", "the build replaces divisions by reciprocals"),
])
def test_ctrl_init_refuses_a_build_that_changes_the_arithmetic(runs, tmp_path, flags, message):
    import platform
    if "-mfma" in flags and not (platform.machine() == "x86_64" and _has_fma()):
        pytest.skip("needs an x86-64 CPU with FMA")
    exp = runs["lyapunov", "observer"][1]
    code, line = _make_check(exp, tmp_path, "unsafe", EXTRA=flags)
    assert code == 2 and line.startswith(f"FAIL ctrl_init: {message}"), line


def test_the_object_needs_no_library_call_with_clang_and_builds_without_clock_monotonic(runs, tmp_path):
    exp = runs["lyapunov", "observer"][1]
    src = re.sub(r"/\*.*?\*/", "", (exp / "frictionrt_ctrl.c").read_text(), flags=re.S)
    assert not re.search(r"[^_]isfinite\s*\(", src.replace("ctrl_isfinite", ""))   # bit tests only
    if shutil.which("clang"):
        obj = tmp_path / "clang.o"
        subprocess.run(["clang", "-std=c99", "-O2", "-ffp-contract=off", "-c", "-o", str(obj),
                        str(exp / "frictionrt_ctrl.c")], check=True)
        assert set(subprocess.run(["nm", "-u", str(obj)], capture_output=True, text=True).stdout.split()) <= {"U", "memcpy"}
    # ctrl_batch.c where time.h declares no CLOCK_MONOTONIC (newlib): a stand-in time.h
    (tmp_path / "inc").mkdir()
    (tmp_path / "inc" / "time.h").write_text("/* a C library without CLOCK_MONOTONIC */\n")
    subprocess.run(["cc", "-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-pedantic", "-Werror",
                    "-I", str(tmp_path / "inc"), "-I", str(exp), "-c", "-o", str(tmp_path / "batch.o"),
                    str(exp / "ctrl_batch.c")], check=True)


# ---- where it runs: the PREEMPT_RT example, cross targets (skipped without their toolchains) ------

def test_the_preempt_rt_example_main_builds(runs, tmp_path):
    import sys
    if not sys.platform.startswith("linux"):
        pytest.skip("the example is for Linux (PREEMPT_RT)")
    work = tmp_path / "rt"
    shutil.copytree(runs["lyapunov", "observer"][1], work)
    p = subprocess.run(["make", "-s", "-C", str(work), "rt_example", "EXTRA=-Werror"], capture_output=True, text=True)
    assert p.returncode == 0 and (work / "ctrl_rt_main").is_file(), p.stderr[-2000:]
    src = (work / "ctrl_rt_main.c").read_text()
    for call in ("mlockall(", "sched_setscheduler(", "SCHED_FIFO", "clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME"):
        assert call in src


def test_aarch64_under_qemu_is_bit_exact_and_its_default_contraction_is_refused(runs, tmp_path):
    cc, qemu = "aarch64-linux-gnu-gcc", "qemu-aarch64"
    if not (shutil.which(cc) and shutil.which(qemu) and os.path.isdir("/usr/aarch64-linux-gnu")):
        pytest.skip("needs gcc-aarch64-linux-gnu and qemu-user (make check-targets installs them)")
    exp = runs["lyapunov", "observer"][1]
    run_ = f"{qemu} -L /usr/aarch64-linux-gnu"
    code, line = _make_check(exp, tmp_path, "a64", CC=cc, AR="aarch64-linux-gnu-ar", RUN=run_, EXTRA="-Werror")
    assert code == 0 and line.startswith("ok: 3150 ticks x 13 outputs bit-exact"), line
    code, line = _make_check(exp, tmp_path, "a64_fma", CC=cc, AR="aarch64-linux-gnu-ar", RUN=run_,
                             EXTRA="-ffp-contract=fast")
    assert code == 2 and line.startswith("FAIL ctrl_init: the build fuses multiply-adds"), line


def test_a_cortex_m7_build_is_warning_free(runs, tmp_path):
    cc = "arm-none-eabi-gcc"
    if not shutil.which(cc):
        pytest.skip("needs gcc-arm-none-eabi (make check-targets installs it)")
    exp = runs["lyapunov", "observer"][1]
    obj = tmp_path / "m7.o"
    flags = ["-mcpu=cortex-m7", "-mfpu=fpv5-d16", "-mfloat-abi=hard", "-mthumb"]
    for src in ("frictionrt_ctrl.c", "ctrl_batch.c", "ctrl_check.c"):
        p = subprocess.run([cc, *flags, "-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-pedantic",
                            "-Werror", "-I", str(exp), "-c", "-o", str(obj), str(exp / src)], capture_output=True, text=True)
        assert p.returncode == 0, (src, p.stderr[-2000:])


# ---- coverage of a replay -------------------------------------------------------------------------

def test_replay_reports_coverage_and_require_coverage_fails_a_law_that_never_left_f_min(runs, capsys, tmp_path):
    log, exp = runs["lyapunov", "observer"]
    capsys.readouterr()
    code, r, _ = run(capsys, "replay", log, "--require-coverage")
    code_c, rc, _ = run(capsys, "replay", log, "--c", exp, "--require-coverage")
    assert code == code_c == 0 and r["coverage"] == rc["coverage"]   # numba and C took the same paths
    cov = r["coverage"]
    assert cov["left_passive"] is True and cov["law_between"] > 0 and cov["ticks"] == TICKS
    assert cov["law_at_F_min"] + cov["law_between"] + cov["law_at_F_max"] == TICKS
    # hysteresis at 380 Hz, 5 N: u0 stays below F_min / K_f = 1.6 um, the law never leaves F_min
    quiet = main(["simulate", "--law", "hysteresis", "--estimator", "observer", "--freq", "380", "--amp", "5",
                  "--duration", "0.05", "--out", str(tmp_path / "quiet"), "--no-rrd", "--json"])
    assert quiet == 0
    capsys.readouterr()
    code, r, err = run(capsys, "replay", tmp_path / "quiet.mcap", "--require-coverage")
    assert r["bit_exact"] is True and r["coverage"]["left_passive"] is False and r["coverage"]["law_between"] == 0
    assert code == 1 and "the hysteresis law never left F_min in 1050 ticks" in err and len(err.strip().splitlines()) == 1
    code, r, err = run(capsys, "replay", tmp_path / "quiet.mcap")
    assert code == 0
    code, r, err = run(capsys, "replay", runs["passive", "observer"][0], "--require-coverage")
    assert code == 0 and r["coverage"]["left_passive"] is None   # the passive law has no state to leave


# ---- a log with a dropped block ------------------------------------------------------------------

def test_a_log_with_a_dropped_block_is_compared_up_to_the_gap_and_reports_the_ranges(runs, capsys, tmp_path):
    """Rows 400..499 of a 1050-tick log dropped (as the paced writer drops a block): the numba and
    the C replay compare ticks 0..399 bit for bit, report 400..499 missing and 500..1049 not
    compared (the log carries no controller state to restart from), and do not call it a mismatch."""
    from frictionrt.rt.log.writer import McapBlockWriter
    log, exp = runs["lyapunov", "observer"]
    rec = read_mcap(log)
    path = tmp_path / "dropped.mcap"
    with McapBlockWriter(path, rec.signals, rec.rate_hz, dict(rec.metadata)) as w:
        w.write_block(0, rec.log[:400])
        w.write_block(500, rec.log[500:])
    capsys.readouterr()
    for extra in ((), ("--c", exp)):
        code, r, _ = run(capsys, "replay", path, *extra)
        assert code == 0 and r["bit_exact"] is True and r["missing_ticks"] == 100, (extra, r.get("first_mismatch_tick"))
        assert r["compared_ranges"] == [[0, 399]] and r["missing_ranges"] == [[400, 499]]
        assert r["not_compared_ranges"] == [[500, TICKS - 1]]


@pytest.mark.skipif(shutil.which(os.environ.get("CC") or "cc") is None, reason="no C compiler")
@pytest.mark.parametrize("law,est", [("lyapunov", "observer"), ("hysteresis", "oracle")])
def test_a_dropped_block_restarts_the_c_from_the_next_key_frame(runs, capsys, tmp_path, law, est):
    """A 0.05 s log with key frames every 250 ticks, rows 300..599 dropped: replay --c sets the C's
    ctrl_state from key frame 750 (ctrl_batch.c ctrl_run_restarts) and is bit-exact on 0..299 and
    750..1049 (the oracle build's u_rel, v_rel of the restart tick from the key frame). The loop with
    the C controller (simulate --controller c:DIR) logs the numba loop's key frames bit for bit: the
    C's state is copied into the loop's arrays before each one is taken."""
    from tests.test_keyframes import drop_rows
    exp = runs[law, est][1]
    base = ["simulate", "--law", law, "--estimator", est, "--freq", "205", "--amp", "5", "--duration", "0.05",
            "--no-rrd", "--json", "--set", "rt.keyframe_ticks=250"]
    assert main([*base, "--out", str(tmp_path / "numba")]) == 0
    assert main([*base, "--out", str(tmp_path / "sil"), "--controller", f"c:{exp}"]) == 0
    a, b = read_mcap(tmp_path / "sil.mcap").keyframes, read_mcap(tmp_path / "numba.mcap").keyframes
    np.testing.assert_array_equal(a.k, np.arange(0, TICKS, 250))
    np.testing.assert_array_equal(a.k, b.k)
    np.testing.assert_array_equal(a.f.view(np.uint64), b.f.view(np.uint64))
    np.testing.assert_array_equal(a.i, b.i)
    path = drop_rows(tmp_path / "numba.mcap", tmp_path / "gap.mcap", 300, 600)
    capsys.readouterr()
    code, r, err = run(capsys, "replay", path, "--c", exp)
    assert code == 0 and r["bit_exact"] is True, err
    assert r["compared_ranges"] == [[0, 299], [750, 1049]] and r["missing_ranges"] == [[300, 599]]
    assert r["not_compared_ranges"] == [[600, 749]] and r["restarted_from"] == [750] and r["ticks"] == 600
