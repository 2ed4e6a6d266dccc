"""Run-time properties of the plant step: no heap allocation, determinism, cached compilation."""
import os
import shutil
from pathlib import Path

import numpy as np

from frictionrt.plant.impulse import hammer_force
from frictionrt.plant.simulate import run
from tests.nrt_probe import assert_no_allocation_per_step


def test_plant_step_does_not_allocate():
    # 10 vs 2000 compiled steps (impacts, stick-slip) under numba's allocation counters
    assert_no_allocation_per_step("""
        import numba, numpy as np
        from frictionrt.plant.impulse import hammer_force
        from frictionrt.plant.model import build_plant
        from frictionrt.plant.newmark import _plant_step
        from frictionrt.rt.common.config import load

        @numba.njit
        def many(x, x_next, U, p, y, wk):
            for k in range(U.shape[0]):
                if k % 2 == 0:
                    _plant_step(k, x, U[k], p, x_next, y, wk)
                else:
                    _plant_step(k, x_next, U[k], p, x, y, wk)

        cfg = load()
        m = build_plant(cfg)
        U = np.column_stack([hammer_force(2000, cfg.dt_s, 200.0, 0.5e-3), np.full(2000, 40.0)])
        x, x_next = m.initial_state(40.0), np.empty(m.state_size)
        y, wk = np.empty(len(m.output_labels())), m.new_work()

        def call(n):
            many(x, x_next, U[:n], m.params, y, wk)
    """)


def test_same_inputs_give_bit_identical_outputs(cfg, reduced):
    n = 3000
    F = hammer_force(n, cfg.dt_s, 500.0, 0.5e-3)  # impacts, stick-slip and a fallback-prone run
    Y1, x1, _ = run(reduced, F, 40.0)
    Y2, x2, _ = run(reduced, F, 40.0)
    assert np.array_equal(Y1, Y2) and np.array_equal(x1, x2)


def test_kernels_are_compiled_with_cache_and_nogil():
    from frictionrt.plant import contact, newmark, simulate
    for f in (contact._jenkins_pair, contact._normal_impulse, newmark._plant_step, newmark._contact_newton,
              newmark._lu_factor, newmark._lu_solve, newmark._triangular_inverses, newmark._inverse_solve,
              simulate._run):
        assert f.targetoptions.get("nogil") is True, f.__name__
        assert type(f._cache).__name__ == "FunctionCache", f.__name__
    # no reference counting in the plant kernels (half the step time at 9 pairs)
    for f in (newmark._plant_step, newmark._substep, newmark._contact_newton, newmark._contact_laws,
              newmark._contact_residual, newmark._lu_factor, newmark._lu_solve, newmark._triangular_inverses,
              newmark._inverse_solve):
        assert f.targetoptions.get("_nrt") is False, f.__name__


def test_checked_step_wrapper(reduced):
    import pytest
    m = reduced
    x = m.initial_state()
    x_next, y, wk = np.empty_like(x), np.empty(len(m.output_labels())), m.new_work()
    with pytest.raises(ValueError, match="state must have shape"):
        m.step(0, x[:-1], np.zeros(2), x_next, y, wk)
    with pytest.raises(ValueError, match="F_exc"):
        m.step(0, x, np.zeros(3), x_next, y, wk)
    it = m.step(0, x, np.array([0.0, m.structure.F_N1_initial]), x_next, y, wk)
    # at the static equilibrium with no excitation nothing moves
    assert it >= 0 and np.allclose(x_next[m.state_slots()["q"]], x[m.state_slots()["q"]], rtol=1e-9, atol=1e-15)


def test_numba_cache_is_keyed_on_the_kernel_sources():
    # numba only re-checks a cached function's own file; a source-hash directory makes an
    # edit to any kernel source start a fresh cache (rt/common/jit_cache.py); CLI and logging
    # modules are not kernel sources, so editing them keeps the compiled kernels
    from frictionrt.plant import newmark, simulate
    from frictionrt.rt.common import jit_cache
    names = {f.relative_to(jit_cache.ROOT).as_posix() for f in jit_cache.kernel_sources()}
    assert {"plant/newmark.py", "rt/loop/tick.py", "rt/loop/pacing.py", "rt/loop/replay.py", "rt/common/config.py", "rt/common/noise.py",
            "tracking/laws.py"} <= names
    assert not names & {"rt/cli/app.py", "rt/log/mcap_log.py", "rt/experiments/stepsine.py", "rt/log/writer.py"}
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    for f in (newmark._plant_step, simulate._run):
        assert Path(f._cache._cache_path).is_relative_to(jit_cache.cache_dir())
    assert len(jit_cache.source_hash()) == 16


def test_editing_a_kernel_in_a_sub_package_changes_the_cache_key(tmp_path):
    # the key must see kernels below rt/'s sub-packages (rt/loop/, rt/common/), not only
    # top-level files: a copy of the tree, one kernel file edited, gives another key
    from frictionrt.rt.common import jit_cache
    for pkg in jit_cache.PACKAGES:
        shutil.copytree(jit_cache.ROOT / pkg, tmp_path / pkg, ignore=shutil.ignore_patterns("__pycache__"))
    key = jit_cache.source_hash(tmp_path)
    assert key == jit_cache.source_hash()
    cli = tmp_path / "rt" / "cli" / "app.py"
    cli.write_text(cli.read_text() + "\n# not a kernel\n")
    assert jit_cache.source_hash(tmp_path) == key
    tick = tmp_path / "rt" / "loop" / "pacing.py"
    tick.write_text(tick.read_text() + "\n# edited kernel\n")
    assert jit_cache.source_hash(tmp_path) != key
