"""Run under NUMBA_NRT_STATS=1 (by tests/test_realtime_properties.py): step the plant with
preallocated buffers inside a compiled loop, 10 and 2000 steps, and print numba's runtime
allocation counts of both calls. Passing arrays in from Python allocates (unboxing), the
same for both calls; any allocation inside the step shows as a difference."""
import numba
import numpy as np
from numba.core.runtime import rtsys

from plant.impulse import hammer_force
from plant.model import build_plant
from plant.newmark import _plant_step
from rt.config import load


@numba.njit(cache=True)
def _step_many(x, x_next, U, p, y, wk):
    for k in range(U.shape[0]):
        if k % 2 == 0:
            _plant_step(k, x, U[k], p, x_next, y, wk)
        else:
            _plant_step(k, x_next, U[k], p, x, y, wk)


if __name__ == "__main__":
    cfg = load()
    m = build_plant(cfg)
    n = 2000
    U = np.column_stack([hammer_force(n, cfg.dt_s, 200.0, 0.5e-3), np.full(n, 40.0)])
    x, x_next = m.initial_state(40.0), np.empty(m.state_size)
    y, wk = np.empty(len(m.output_labels())), m.new_work()
    _step_many(x.copy(), x_next, U[:4], m.params, y, wk)  # compile
    counts = []
    for steps in (10, n):
        before = rtsys.get_allocation_stats()
        _step_many(x, x_next, U[:steps], m.params, y, wk)
        after = rtsys.get_allocation_stats()
        counts += [after.alloc - before.alloc, after.free - before.free]
    print(*counts, int(np.all(np.isfinite(x))))
