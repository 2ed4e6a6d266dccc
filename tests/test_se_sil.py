"""The C export as the loop's controller on an imported structure (simulate --structure --controller
c:DIR, rt/export/sil.py): the small 3-D reference (plant.fe3d, 39 points) coarsened to 8 points,
the hysteresis law with the observer designed from the superelement; 0.05 s (1050 ticks).
Skipped without the [fe] extra (scikit-fem builds the structure)."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("skfem")

from frictionrt import jobs  # noqa: E402
from frictionrt.plant import fe3d  # noqa: E402
from frictionrt.plant import superelement as S  # noqa: E402
from frictionrt.rt.cli.app import main  # noqa: E402
from frictionrt.rt.common.config import Config  # noqa: E402
from frictionrt.rt.log.mcap_log import read_mcap  # noqa: E402

COARSE = {"interface_pitch_m": 0.04, "pitch_m": 0.05, "cutoff_hz": 4000.0}


def test_simulate_with_the_c_controller_on_a_structure_logs_the_numba_loops_bits(tmp_path):
    """The loop on the imported plant with the C export's controller (called from the compiled loop)
    writes the numba controller's log bit for bit: every signal but the tick's wall-clock columns,
    over 1050 ticks of 5 N at 200 Hz (the hysteresis law moves F_N1, so the C's force tracking and
    observer act on the superelement's own contact forces)."""
    from frictionrt.rt.loop import build_loop
    from frictionrt.rt.loop.driver import run
    from frictionrt.rt.loop.structure import structure_of
    cfg = Config()
    se, _ = fe3d.reference_superelement(cfg, **COARSE)
    f = S.save(S.coarsen(se, 8), tmp_path / "s8.npz")
    exp = tmp_path / "c8"
    jobs.export_c(cfg, out=exp, law="hysteresis", estimator="observer", structure=f, clusters=0)
    assert main(["simulate", "--structure", str(f), "--law", "hysteresis", "--controller", f"c:{exp}",
                 "--freq", "200", "--amp", "5", "--duration", "0.05", "--out", str(tmp_path / "c"), "--no-rrd",
                 "--json"]) == 0
    rec = read_mcap(tmp_path / "c.mcap")
    loop = build_loop(cfg, "hysteresis", "observer", structure=structure_of(f))
    ref = run(loop, 200.0, 5.0, 0.05, seed=cfg.rt.seed).log
    names = [n for n, _, _ in loop.signals if n not in ("tick_ns", "late_ns")]
    a = rec.log[:, [rec.column(n) for n in names]]
    b = ref[:, [loop.column(n) for n in names]]
    assert a.shape == (1050, len(names)) and np.ptp(b[:, loop.column("F_N1")]) > 1.0
    assert (a.view(np.uint64) == b.view(np.uint64)).all()
