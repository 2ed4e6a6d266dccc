"""The Python API (``import frictionrt``): its face, the same defaults as the command line, one
package name in a user's environment, and the command line's input defects fixed (a frequency
of 0 Hz, a closed pipe, list syntax, negative lists)."""
from __future__ import annotations

import inspect
import json
import subprocess
import sys
from pathlib import Path

import pytest

import frictionrt as fr
from frictionrt.rt.cli.app import build_parser, main

ROOT = Path(__file__).resolve().parents[1]


def _defaults(verb: str) -> dict:
    ap = build_parser()
    sub = next(a for a in ap._actions if a.dest == "command").choices[verb]
    return {a.dest: a.default for a in sub._actions}


def _params(fn) -> dict:
    return {k: p.default for k, p in inspect.signature(fn).parameters.items()}


def test_every_name_of_the_face_resolves():
    assert set(fr.__all__) >= {"load_config", "simulate", "tune", "reproduce", "diagnose", "import_frf", "Estimator"}
    for name in fr.__all__:
        assert getattr(fr, name) is not None, name


@pytest.mark.parametrize("verb, fn, pairs", [
    # (CLI dest, API parameter, how the CLI spells the API's value)
    ("simulate", "simulate", [("duration", "duration_s", None), ("estimator", "estimator", None),
                              ("ring", "ring_s", None), ("law", "law", None), ("seed", "seed", None)]),
    ("tune", "tune", [("points", "points", None), ("half_width", "half_width", None), ("estimator", "estimator", None),
                      ("amps", "amps_n", lambda v: tuple(v)), ("modes", "modes", lambda v: tuple(map(int, v.split(",")))),
                      ("max_power", "max_power_w", None), ("jobs", "jobs", None)]),
    ("frf", "frf", [("points", "points", None), ("half_width", "half_width", None), ("tol", "tol", None),
                    ("max_time", "max_time_s", None), ("estimator", "estimator", None), ("down", "down", None)]),
    ("compare", "compare", [("mode", "mode", None), ("amp", "amp_n", None), ("duration", "duration_s", None),
                            ("estimator", "estimator", None)]),
    ("rig", "rig", [("seed", "seed", None), ("record_s", "record_s", None), ("quantity", "quantity", None),
                    ("excitation", "excitation", None), ("stepsine", "stepsine", None)]),
    ("export-c", "export_c", [("estimator", "estimator", None), ("law", "law", None)]),
])
def test_the_cli_and_the_python_function_have_the_same_defaults(verb, fn, pairs):
    cli, api = _defaults(verb), _params(getattr(fr, fn))
    for dest, param, spell in pairs:
        value = cli[dest] if spell is None else spell(cli[dest])
        assert value == api[param], f"{verb} --{dest}: CLI {value!r}, Python {param}={api[param]!r}"


def test_one_estimator_default_everywhere():
    from frictionrt.rt.experiments.tune import tune
    from frictionrt.rt.loop import build_loop
    assert fr.DEFAULT_ESTIMATOR is fr.Estimator.OBSERVER == "observer"
    for f in (build_loop, tune, fr.simulate, fr.compare, fr.frf, fr.tune, fr.export_c):
        assert _params(f)["estimator"] == "observer", f.__qualname__
    assert _defaults("reproduce")["estimator"] == "both" and _params(fr.reproduce)["estimators"] == fr.ESTIMATORS
    with pytest.raises(ValueError, match="estimator 'kalman': give one of observer, oracle"):
        fr.simulate(freq_hz=200.0, amp_n=5.0, estimator="kalman")


def test_nothing_generic_is_importable_outside_the_clone(tmp_path):
    # the card's folders install under frictionrt only: from a folder outside the clone, `import rt`
    # (or plant, observer, tracking) finds nothing; inside the clone each module has one name
    code = ("import importlib.util, frictionrt; "
            "print([n for n in ('rt', 'plant', 'observer', 'tracking') if importlib.util.find_spec(n)])")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
    loaded = [m for m in sys.modules if m.split(".")[0] in ("rt", "plant", "observer", "tracking")]
    assert not loaded, f"modules imported under a second name: {loaded[:5]}"


def test_a_job_refuses_zero_hz_and_nyquist_with_one_range():
    for f in (0.0, 10500.0, -5.0, float("nan")):
        with pytest.raises(ValueError, match=r"give a frequency in \(0, 10500\) Hz"):
            fr.check_frequency(f)
    assert fr.check_frequency(200.0) == 200.0


def test_simulate_at_zero_hz_is_refused_before_the_run(capsys):
    # it used to run, then end in a ZeroDivisionError traceback in first_harmonic_amplitude
    assert main(["simulate", "--freq", "0", "--amp", "5", "--duration", "0.01"]) == 2
    err = capsys.readouterr().err
    assert "--freq 0 Hz: give a frequency in (0, 10500) Hz" in err and "Traceback" not in err


@pytest.mark.parametrize("argv", [["modes"], ["rig", "--list"], ["config", "--show"]])
def test_output_into_a_closed_pipe_ends_quietly(argv):
    # `frictionrt modes | head -1`: the reader goes away; exit 141 (SIGPIPE's), no traceback
    p = subprocess.Popen([sys.executable, "-m", "frictionrt", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait() in (0, 141) and "Traceback" not in err and "BrokenPipe" not in err, err


def test_lists_take_comma_syntax_and_the_old_spelling_with_a_note(capsys):
    ap = build_parser()
    assert ap.parse_args(["tune", "--law", "hysteresis", "--amps", "5,20"]).amps == [5.0, 20.0]
    old = ap.parse_args(["tune", "--law", "hysteresis", "--amp", "5", "20"])
    assert old.amps == [5.0, 20.0]
    assert "--amp 5,20" in capsys.readouterr().err                 # the note says the new spelling
    assert ap.parse_args(["frf", "--law", "passive,lyapunov", "--amps", "5", "--freqs", "200"]).law == [
        "passive", "lyapunov"]
    with pytest.raises(SystemExit):
        ap.parse_args(["frf", "--law", "passive,nope", "--amps", "5", "--freqs", "200"])
    assert "'nope': give one or more of passive, hysteresis, lyapunov" in capsys.readouterr().err


def test_a_list_that_starts_with_a_minus_reaches_its_own_check(capsys):
    # argparse took "-5,200" for an option ("expected one argument"); now the value is checked
    assert main(["frf", "--law", "passive", "--amps", "5", "--freqs", "-5,200"]) == 2
    assert "--freqs -5 Hz" in capsys.readouterr().err


def test_help_shows_a_configuration_default_as_its_value():
    out = subprocess.run([sys.executable, "-m", "frictionrt", "simulate", "--help"], capture_output=True, text=True,
                         check=True).stdout
    flat = " ".join(out.split())
    assert "(default: tracking.law = passive)" in flat and "(default: rt.seed = 0)" in flat


def test_results_serialise_and_plot():
    res = fr.impulse(fn1_n=100.0)
    doc = json.loads(res.to_json())
    assert doc == res.to_dict() and doc["fn1_n"] == 100.0 and len(doc["freq_hz"]) == 4
    # mode 3 at F_N1 = 100 N: the contact is calibrated to the paper's 230 Hz (docs/plant.md)
    assert 220.0 < res["freq_hz"][1] < 240.0
    fig = res.plot()
    assert fig.axes and fig.axes[0].get_xlabel() == "frequency [Hz]"
    with pytest.raises(TypeError, match="has no plot"):
        fr.modes().plot()
