"""Other assemblies from configuration alone: a bolted lap joint and a moved damper."""
from pathlib import Path

import numpy as np

from frictionrt.plant.energy import balance
from frictionrt.plant.impulse import hammer_force
from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from frictionrt.plant.simulate import run
from frictionrt.rt.common.config import load

LAP_JOINT = Path(__file__).resolve().parents[1] / "configs" / "lap_joint.toml"
MOVED_DAMPER = ["plant.beams.damper.x0_m=0.30", "plant.interface.x_start_m=0.30", "plant.interface.x_end_m=0.46",
                "plant.screws.normal.x_m=0.31", "plant.screws.adaptive.x_m=0.45"]


def _check_assembly(cfg):
    full, red = build_plant(cfg, reduced=False), build_plant(cfg)
    f_full, f_red = stuck_frequencies_hz(full), stuck_frequencies_hz(red)
    k = f_full < 2000.0
    # the same Craig-Bampton criterion as the benchmark structure (SPEC 2: 0.5 %)
    assert np.max(np.abs(f_red[: k.sum()] / f_full[k] - 1)) < 5e-3
    adaptive = next(s for s in cfg.plant.screws if s.adaptive)
    j = int(np.argmin(np.abs(red.structure.x_pairs - adaptive.x_m)))
    assert preloaded_pairs(red)[j]  # the adaptive screw closes its own pair
    n = int(round(0.1 / cfg.dt_s))
    x0 = red.initial_state()
    Y, x, _ = run(red, hammer_force(n, cfg.dt_s, 50.0, 0.5e-3), adaptive.F_N, x0=x0)
    b = balance(red, x0, x)
    assert abs(b["residual"]) < 1e-6 * b["W_exc"]
    return red, Y


def test_lap_joint_from_toml_only():
    cfg = load(LAP_JOINT)
    assert {b.name for b in cfg.plant.beams} == {"A", "B"}
    red, Y = _check_assembly(cfg)
    # beam B hangs on the joint only: its tip moves under the hammer on beam A
    assert np.abs(Y[:, red.output_index()["w_tip"]]).max() > 1e-7


def test_damper_at_another_position_by_set():
    cfg = load(sets=MOVED_DAMPER)
    red, _ = _check_assembly(cfg)
    np.testing.assert_allclose(red.structure.x_pairs[[0, -1]], [0.30, 0.46], atol=1e-12)


def test_contact_points_between_nodes_read_the_elements_interpolation():
    """docs/plant.md 1.3: a contact pitch finer than the elements puts points between nodes; their
    gaps are the frame elements' own fields there (u linear, w cubic Hermite, theta = dw/dx), so a
    field the elements represent exactly (u linear, w cubic, zero at the main beam's clamp) gives
    the exact gaps at every point, and only the nodes around the points become boundary DOFs."""
    from frictionrt.plant.fe_beam import DOFS_PER_NODE, THETA, U, W
    from frictionrt.plant.structure import build_structure, node_pairs

    cfg = load(sets=["plant.interface.pitch_m=0.0025", "plant.interface.end_refinement=1",
                     "plant.element_length_m=0.01"])
    st = build_structure(cfg)
    assert len(st.x_pairs) == 65 and len(node_pairs(st.x_pairs, 0.01)) == 17   # 3 of every 4 points between nodes
    fields = {"main": (3e-4, -2e-3, 5e-6), "damper": (-4e-4, 1e-3, -2e-6)}        # w = a x^2 + b x^3, u = c x
    X = np.zeros(sum(s.n for s in st.subs))
    for s in st.subs:
        a, b, c = fields[s.beam.name]
        full = np.zeros(DOFS_PER_NODE * len(s.x_nodes))
        x = s.x_nodes
        full[U::3], full[W::3], full[THETA::3] = c * x, a * x**2 + b * x**3, 2 * a * x + 3 * b * x**2
        X[s.offset:s.offset + s.n] = full[s.free]
    h = {b.name: b.height_m for b in cfg.plant.beams}
    (au, bu, cu), (al, bl, cl) = fields["damper"], fields["main"]
    x = st.x_pairs
    g_n = (au - al) * x**2 + (bu - bl) * x**3
    g_t = (cu - cl) * x + h["damper"] / 2 * (2 * au * x + 3 * bu * x**2) + h["main"] / 2 * (2 * al * x + 3 * bl * x**2)
    np.testing.assert_allclose(st.gap_rows[0::2] @ X, g_n, rtol=0, atol=1e-15)
    np.testing.assert_allclose(st.gap_rows[1::2] @ X, g_t, rtol=0, atol=1e-15)


def test_the_default_layout_refines_the_contact_pitch_at_both_ends():
    """docs/plant.md 6.3: 10 mm points with each of the three 10 mm pitches nearest either end of the
    160 mm interface halved (end_refinement 2, end_zone_m 30 mm): 23 points; a zone is rounded up to
    whole pitches (25 mm gives the same points), zones that meet refine the whole interface (33
    points, 5 mm everywhere), and end_refinement 1 is the uniform 10 mm grid (17 points)."""
    from frictionrt.plant.structure import build_structure

    def spacing_mm(sets):
        return np.round(np.diff(build_structure(load(sets=sets)).x_pairs) * 1e3, 9)

    assert spacing_mm([]).tolist() == [5.0] * 6 + [10.0] * 10 + [5.0] * 6
    assert spacing_mm(["plant.interface.end_zone_m=0.025"]).tolist() == spacing_mm([]).tolist()
    assert spacing_mm(["plant.interface.end_zone_m=0.09"]).tolist() == [5.0] * 32
    assert spacing_mm(["plant.interface.end_refinement=1"]).tolist() == [10.0] * 16
