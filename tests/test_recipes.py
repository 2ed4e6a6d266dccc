"""The guide's four recipes (docs/recipes/), each run as its example script (docs/examples/, the
small version: FRICTIONRT_EXAMPLES_QUICK=1) and as the command line, with equal results (the
reproduction's CLI twin in `make test-slow`; the diagnosis compares the CLI's import, whose files the
same job then reads): a broken example fails here."""
from __future__ import annotations

import json
import os
import runpy
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "docs" / "examples"


def run_example(name: str, out: Path, monkeypatch) -> dict:
    """The example's globals after it ran in this process, its outputs in ``out``."""
    monkeypatch.setenv("FRICTIONRT_EXAMPLES_QUICK", "1")
    monkeypatch.setenv("FRICTIONRT_EXAMPLES_OUT", str(out))
    return runpy.run_path(str(EXAMPLES / name), run_name="__main__")


def cli_json(*args) -> dict:
    r = subprocess.run([sys.executable, "-m", "frictionrt", *map(str, args), "--json"], capture_output=True, text=True,
                       env=os.environ | {"LOKY_MAX_CPU_COUNT": "1"})
    assert r.returncode == 0, r.stderr[-2000:]
    return json.loads(r.stdout)


def test_every_recipe_has_its_example():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == ["diagnose_frfs.py", "inspect_run.py",
                                                            "reproduce_paper.py", "tune_gain.py"]
    for p in EXAMPLES.glob("*.py"):
        assert p.read_text().startswith("# %% [markdown]"), f"{p.name}: a jupytext percent script"


def test_inspect_a_run(tmp_path, monkeypatch):
    g = run_example("inspect_run.py", tmp_path / "py", monkeypatch)
    py = g["res"].to_dict()
    cli = cli_json("simulate", "--law", "lyapunov", "--freq", "205", "--amp", "5", "--duration", "0.2",
                   "--out", tmp_path / "cli.mcap")
    for key in ("acc045_amplitude", "fn1_mean_n", "actuator_energy_j", "v_rel_nrmse", "ticks"):
        assert py[key] == cli[key], key                       # the same bits from Python and the CLI
    for key in ("mcap", "rrd", "foxglove_layout"):
        assert Path(py[key]).stat().st_size > 0 and Path(cli[key]).stat().st_size > 0
    assert (tmp_path / "py" / "run.png").exists()


def test_tune_a_gain(tmp_path, monkeypatch):
    g = run_example("tune_gain.py", tmp_path / "py", monkeypatch)
    py = g["res"].to_dict()
    cli = cli_json("tune", "--law", "lyapunov", "--grid", "tracking.eps_m_s=0.01,0.03", "--modes", "3",
                   "--amps", "5", "--points", "5", "--jobs", "1", "--out", tmp_path / "cli")
    assert [r["peak_change_db"] for r in py["candidates"]] == [r["peak_change_db"] for r in cli["candidates"]]
    assert [r["power_w"] for r in py["candidates"]] == [r["power_w"] for r in cli["candidates"]]
    assert py["best"] == cli["best"] and py["warnings"] == cli["warnings"]
    assert (tmp_path / "py" / "tune" / "best.toml").exists() and (tmp_path / "py" / "tune_pareto.png").exists()


def test_reproduce_the_paper(tmp_path, monkeypatch):
    g = run_example("reproduce_paper.py", tmp_path / "py", monkeypatch)
    py = g["res"].to_dict()
    assert list(py["by_estimator"]) == ["observer"]
    assert set(py["by_estimator"]["observer"]["claims"]) >= {"C3", "C4", "C5", "C6"}
    assert (tmp_path / "py" / "reproduce" / "report.md").exists()


@pytest.mark.slow   # the CLI twin of the recipe's run (~70 s); the suite's CLI reproduce is test_reproduce.py's
def test_reproduce_the_paper_from_the_cli_gives_the_examples_result(tmp_path, monkeypatch):
    g = run_example("reproduce_paper.py", tmp_path / "py", monkeypatch)
    py = g["res"].to_dict()
    cli = cli_json("reproduce", "--quick", "--modes", "3", "--estimator", "observer", "--error-estimate", "none",
                   "--out", tmp_path / "cli")
    assert list(py["by_estimator"]) == list(cli["by_estimator"]) == ["observer"]
    for est in ("observer",):
        assert py["by_estimator"][est]["peak_change_db"] == cli["by_estimator"][est]["peak_change_db"]
        assert py["by_estimator"][est]["claims"] == cli["by_estimator"][est]["claims"]
    assert (tmp_path / "py" / "reproduce" / "report.md").exists()


def test_diagnose_your_frfs(tmp_path, monkeypatch):
    g = run_example("diagnose_frfs.py", tmp_path / "py", monkeypatch)
    py = g["diag"].to_dict()
    path, t = g["exports"][0]
    pos = ",".join(f"{s}={x!r}" for s, x in t.meta["sensor_positions_m"].items())
    subprocess.run([sys.executable, "-m", "frictionrt", "import-frf", str(path), "--sensor-positions", pos,
                    "--excitation-x", repr(t.meta["excitation_x_m"]), "--fn1", repr(t.F_N1), "-o",
                    str(tmp_path / "cli_frf")], check=True, capture_output=True)
    imported = sorted((tmp_path / "py" / "lab_frf").iterdir())
    # the same files from the CLI's import, so the CLI's diagnose (frictionrt.jobs.diagnose, the
    # example's function: tests/test_api.py compares their defaults) reads what the example read
    assert [p.read_bytes() for p in imported] == [p.read_bytes() for p in sorted((tmp_path / "cli_frf").iterdir())]
    assert py["gap_after"]["structure_frf_db"] <= py["gap_before"]["structure_frf_db"]
