"""The determinism guarantee of docs/determinism.md, on the committed fixture (tests/fixtures).

The fixture was written on another machine with the default code generation (generic x86-64,
rt/common/codegen.py). Replayed here, the controller and the plant must reproduce it bit for bit; with
this machine's BLAS replaced by OpenBLAS's oldest kernels and glibc's FMA variants masked (a
machine that computes differently at design time and in libm) still bit for bit, because the
log carries its design arrays and the kernels call no CPU-dependent libm on the replay path;
under another code generation the controller bit for bit and the plant within the stated bound.
A failure names what changed (kernel sources, versions, code generation).
"""
import json
import os
import subprocess
import sys

import pytest

from frictionrt.rt.common.codegen import compiled_target
from frictionrt.rt.log.mcap_log import read_mcap
from frictionrt.rt.loop.replay import replay
from frictionrt.rt.loop.replay_plant import replay_plant
from tests.fixtures.make_fixtures import FIXTURE

# another code generation: each /plant and /actuator signal within this fraction of its range over
# the fixture (measured 2.5e-12 on accelerations, generic against znver5 with AVX-512 and FMA; the
# contact's Newton iteration count, newton_iter, may differ by a few: it is not compared)
OTHER_TARGET_REL = 1e-7


def fixture_meta() -> dict:
    return read_mcap(FIXTURE).metadata


def same_target() -> bool:
    t = json.loads(fixture_meta()["codegen"])
    cur = compiled_target()
    return (t["cpu"], t["features"]) == (cur["cpu"], cur["features"])


def explain(res: dict) -> str:
    env = res["design"]["environment"]
    return ("changed since the fixture was written: " + ", ".join(env) +
            ("; regenerate it with python -m tests.fixtures.make_fixtures if the change is meant to change "
             "a run's numbers" if any(e.startswith("kernel sources") for e in env) else "")) if env else \
        "nothing in the set-up changed: this machine computes differently (docs/determinism.md)"


def replay_in_subprocess(env_extra: dict, plant: bool) -> dict:
    env = dict(os.environ, **env_extra)
    if env.get("FRICTIONRT_CPU") == "host":
        env.pop("NUMBA_CPU_NAME", None)   # rt/common/codegen.py put it into this process's environment
    cmd = [sys.executable, "-m", "frictionrt.rt.cli", "replay", str(FIXTURE), "--json"] + (["--plant"] if plant else [])
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode in (0, 1), p.stderr
    return json.loads(p.stdout)


def within_bound(res: dict) -> list[str]:
    """Signals whose replayed values differ by more than OTHER_TARGET_REL of their recorded range."""
    rec = read_mcap(FIXTURE)
    names = [n for n, _, _ in rec.signals]
    bad = []
    for name, diff in res["max_abs_diff_by_signal"].items():
        if name == "newton_iter" or diff == 0.0:
            continue
        col = rec.log[:, names.index(name)]
        span = float(col.max() - col.min())
        if not diff <= OTHER_TARGET_REL * max(span, 1e-300):
            bad.append(f"{name} {diff:.3g} (range {span:.3g})")
    return bad


def test_the_fixture_replays_bit_exact_through_the_controller():
    res = replay(FIXTURE)
    assert res["ticks"] == 1050 and res["design"]["source"] == "log"
    assert res["bit_exact"] is True, explain(res)   # also under another code generation: no fastmath


def test_the_fixture_replays_into_the_plant_as_promised():
    res = replay_plant(FIXTURE)
    assert res["ticks"] == 1050 and res["design"]["source"] == "log" and res["failed_solves"] == 0
    # not vacuous: the stack was driven and the structure rang
    assert res["outputs"]["F_N1"]["max"] - res["outputs"]["F_N1"]["min"] > 30.0   # measured 49.9 N (67 N on the 20 mm plant)
    if same_target():
        assert res["bit_exact"] is True, explain(res)
    else:
        assert within_bound(res) == [], explain(res)


def test_other_blas_kernels_and_libm_variants_replay_the_fixture_bit_exact():
    """OpenBLAS's Prescott kernels (no AVX) build a different model from the same configuration
    (eigenvector signs, last bits); glibc without its AVX2/FMA variants gives other last bits of
    atan, exp, sin. The replay uses the logged design and a libm-free atan: the same bits."""
    env = {"OPENBLAS_CORETYPE": "Prescott", "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F,-AVX"}
    for plant in (False, True):
        res = replay_in_subprocess(env, plant)
        if plant and not same_target():
            assert within_bound(res) == [], explain(res)
        else:
            assert res["bit_exact"] is True, explain(res)
        assert res["design"]["source"] == "log"


@pytest.mark.parametrize("plant", [False, True])
def test_another_code_generation_keeps_the_controller_bit_exact_and_the_plant_within_the_bound(plant):
    other = "host" if compiled_target()["features"] == "" else "generic"
    env = {"FRICTIONRT_CPU": other}
    res = replay_in_subprocess(env, plant)
    assert res["design"]["source"] == "log"
    if not plant:
        assert res["bit_exact"] is True, explain(res)
    else:
        assert within_bound(res) == [], explain(res)
