"""The plant step the loop calls: the built-in beams' (``plant.newmark._plant_step``) or an
imported structure's (``plant.se_plant._se_step``), chosen at compile time by the type of its
parameters (``PlantParams`` or ``SEParams``). Both take ``(k, x, u, p, x_next, y, wk)`` with
u = (F_exc [N], the stack force F_N1 [N] held over the tick) and return the Newton iterations
(-1 on a failed solve); their outputs name the same signals the loop reads (u_rel, v_rel,
abar_<point>, dF_N1, w_<point>, v_<point>, F_N1).

The dispatch is numba's ``overload``: the loop compiled for the built-in plant calls
``_plant_step`` exactly as before (the same machine code), and the imported structure's loop is a
second compilation of the same loop."""
from __future__ import annotations

from numba.core import types
from numba.extending import overload

from frictionrt.plant.newmark import _plant_step
from frictionrt.plant.se_plant import SEParams, _se_step


def plant_step(k, x, u, p, x_next, y, wk):
    """One controller step of either plant (module docstring); in Python, the kernel for p's type."""
    step = _se_step if isinstance(p, SEParams) else _plant_step
    return step(k, x, u, p, x_next, y, wk)


def is_superelement(p) -> bool:
    """True for the numba type of ``SEParams`` (compile time)."""
    return isinstance(p, types.BaseNamedTuple) and p.instance_class is SEParams


@overload(plant_step, inline="always")
def _plant_step_of(k, x, u, p, x_next, y, wk):
    if is_superelement(p):
        def se(k, x, u, p, x_next, y, wk):
            return _se_step(k, x, u, p, x_next, y, wk)
        return se

    def beams(k, x, u, p, x_next, y, wk):
        return _plant_step(k, x, u, p, x_next, y, wk)
    return beams
