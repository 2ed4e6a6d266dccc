"""The amplitude-following observer in the C export (rt/export, templates' ``amplitude_step``;
docs/export-c.md): a run log of that kind replays bit for bit through the C exported from the log,
its golden vectors pass ``make check`` with each square-root path (the SSE2 instruction, libm's
sqrt), the object calls no library function and has no mutable globals, an FMA build is refused
by ctrl_init, the Jenkins joint's branch is bit-exact too, and the float32 kind refuses it in one
line. One log of 0.05 s (1050 ticks) and one export keep it short."""
import dataclasses
import json
import platform
import subprocess

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.export.cbuild import OUTPUTS
from frictionrt.rt.log.mcap_log import read_mcap
from tests.test_export_c import _has_fma, _make_check

TICKS = 1050


@pytest.fixture(scope="module")
def amp(tmp_path_factory):
    """(log, export, loop): the hysteresis law on the amplitude-following observer at mode 4's
    passive peak, 10 N, 0.05 s; the C exported from the design that log carries (what
    ``export-c --from-log`` does: ``log_design``, then ``export_c``) and that loop."""
    from frictionrt.rt.export.generate import export_c
    from frictionrt.rt.export.replay_c import log_design
    d = tmp_path_factory.mktemp("export_amplitude")
    assert main(["simulate", "--law", "hysteresis", "--estimator", "amplitude", "--freq", "370.2", "--amp", "10",
                 "--duration", "0.05", "--out", str(d / "amp"), "--no-rrd", "--json"]) == 0
    log = d / "amp.mcap"
    _, _, _, loop, st, _ = log_design(log)
    export_c(loop, st, d / "c", f"the log {log}")
    return log, d / "c", loop




def test_an_amplitude_log_replays_bit_exact_through_the_c_exported_from_it(amp, capsys):
    log, exp, _ = amp
    capsys.readouterr()
    code = main(["replay", str(log), "--c", str(exp), "--json"])
    r = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert code == 0 and r["bit_exact"] is True and r["ticks"] == TICKS and r["first_mismatch_tick"] is None
    assert r["signals_compared"] == list(OUTPUTS) and r["estimator"] == "amplitude"
    assert r["design_hash"] == r["log_design_hash"] == read_mcap(log).metadata["controller_design"]
    m = json.loads((exp / "frictionrt_export.json").read_text())
    assert (m["estimator"], m["design_hash"]) == ("amplitude", r["design_hash"])
    cfg_h = (exp / "ctrl_config.h").read_text()
    assert "#define CTRL_AMPLITUDE 1" in cfg_h and "#define CTRL_N_GRID 11" in cfg_h
    rec = read_mcap(log)   # not vacuous: RT1's u0 grew and the estimate left the grid's first cell (0.5 um)
    u0 = rec.log[:, rec.column("u0")]
    assert u0[-1] > u0[0] and np.abs(rec.log[:, rec.column("u_rel_hat")]).max() > 0.5e-6


def test_golden_vectors_pass_with_either_square_root_and_the_object_calls_no_library_function(amp, tmp_path):
    """The SSE2 instruction (x86-64's default), then libm's sqrt (__SSE2__ undefined: the
    fallback of a target without a known instruction): both correctly rounded, both bit-exact. The
    first build's object calls no library function and has no mutable globals."""
    exp = amp[1]
    if platform.machine() != "x86_64":
        pytest.skip("the SSE2 path needs x86-64")
    digest = json.loads((exp / "frictionrt_export.json").read_text())["design_hash"]
    assert _make_check(exp, tmp_path, "sse2", EXTRA="-Werror") == (0, f"ok: 3150 ticks x 13 outputs bit-exact, design {digest}")
    obj = tmp_path / "sse2" / "frictionrt_ctrl.o"
    assert subprocess.run(["nm", "-u", str(obj)], capture_output=True, text=True).stdout.strip() == ""
    text, data, bss = map(int, subprocess.run(["size", str(obj)], capture_output=True, text=True)
                          .stdout.splitlines()[1].split()[:3])
    assert text > 0 and data == 0 and bss == 0
    code, line = _make_check(exp, tmp_path, "libm", EXTRA="-U__SSE2__")
    assert code == 0 and line.startswith("ok: 3150 ticks"), line
    assert "sqrt" in subprocess.run(["nm", "-u", str(tmp_path / "libm" / "frictionrt_ctrl.o")], capture_output=True,
                                    text=True).stdout   # the fallback did run


def test_ctrl_init_refuses_an_fma_build_of_the_amplitude_kind(amp, tmp_path):
    if not (platform.machine() == "x86_64" and _has_fma()):
        pytest.skip("needs an x86-64 CPU with FMA")
    code, line = _make_check(amp[1], tmp_path, "fma", EXTRA="-ffp-contract=fast -mfma")
    assert code == 2 and line.startswith("FAIL ctrl_init: the build fuses multiply-adds"), line


def test_the_jenkins_joint_branch_is_bit_exact_in_the_golden_vectors(amp, tmp_path):
    """The kind with the joint as a Jenkins element (one more state, the slider; the benchmark's
    ``jenkins``): its export's golden vectors (the numba controller's outputs) pass make check,
    and both the stuck and the slipping branch ran."""
    from frictionrt.observer.amplitude import design_amplitude
    from frictionrt.rt.export.generate import export_c
    from frictionrt.rt.loop import initial_loop_state
    base = amp[2]
    loop = dataclasses.replace(base, amplitude=design_amplitude(base.cfg, base.plant, jenkins=True)[1])
    st = initial_loop_state(loop, loop.cfg.rt.seed)
    assert st.xe.shape == (15,)
    m = export_c(loop, st, tmp_path / "c", "the Jenkins joint")
    assert "#define CTRL_N_STATE 15" in (tmp_path / "c" / "ctrl_config.h").read_text()
    code, line = _make_check(tmp_path / "c", tmp_path, "jenkins")
    assert code == 0 and line == f"ok: 3150 ticks x 13 outputs bit-exact, design {m['design_hash']}", line
    # both branches ran: the joint's force at its slip limit mu |F_N| (slipping) and inside it (stuck)
    gin, gout = ([ln.split() for ln in (tmp_path / "c" / f).read_text().splitlines() if not ln.startswith("#")]
                 for f in ("golden_in.txt", "golden_out.txt"))
    bits = lambda rows, j: np.array([int(r[j], 16) for r in rows], dtype=np.uint64).view(np.float64)  # noqa: E731
    f_r, F_cell = bits(gout, OUTPUTS.index("f_r_hat")), bits(gin, 4)
    at_limit = np.abs(f_r) == loop.observer.mu * np.abs(F_cell)
    assert 0.05 < at_limit.mean() < 0.95


def test_the_float32_kind_refuses_the_amplitude_observer_in_one_line(tmp_path, capsys):
    code = main(["export-c", "--estimator", "amplitude", "--precision", "float32", "-o", str(tmp_path / "c")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "only the observer build" in err[0] and "'amplitude'" in err[0]
    assert not (tmp_path / "c").exists()
