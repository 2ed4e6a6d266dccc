"""The superelement format (plant.superelement): round trips through every reader, unit conversion,
tmdsimpy's Brake-Reuss layout, and the one-line errors on bad input."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.io as sio

from frictionrt.plant import superelement as S


def _toy(p: int = 3, d: int = 3, n: int = 8, seed: int = 0) -> S.Superelement:
    """A random but valid superelement: SPD K and M, p points with d gap rows each."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    K = A @ A.T + n * np.eye(n)
    B = rng.standard_normal((n, n))
    M = 1e-3 * (B @ B.T + n * np.eye(n))
    return S.Superelement(M=M, K=K, contact_rows=rng.standard_normal((p, d, n)), contact_area=np.full(p, 2e-4),
                          f_bolts=rng.standard_normal(n), adaptive_row=rng.standard_normal(n), adaptive_k=1e7,
                          u_rel_row=rng.standard_normal(n), u_rel_direction=np.array([1.0, 0.0, 0.0]),
                          sensor_rows=rng.standard_normal((2, n)), sensor_names=("tip", "frf"),
                          excitation=rng.standard_normal((1, n)), excitation_names=("exc",))


def _same(a: S.Superelement, b: S.Superelement, rtol=0.0):
    for k in S.ARRAY_KEYS:
        x, y = getattr(a, k), getattr(b, k)
        assert (x is None) == (y is None), k
        if x is not None:
            np.testing.assert_allclose(y, x, rtol=rtol, atol=0, err_msg=k)
    assert a.adaptive_k == pytest.approx(b.adaptive_k, rel=rtol)
    assert a.sensor_names == b.sensor_names and a.excitation_names == b.excitation_names


def test_npz_round_trip_is_exact(tmp_path):
    se = _toy()
    _same(se, S.load(S.save(se, tmp_path / "s.npz")))


def test_mat_v5_round_trip(tmp_path):
    se = _toy()
    d = S.to_dict(se)
    sio.savemat(tmp_path / "s.mat", d)
    _same(se, S.load(tmp_path / "s.mat"))


def test_mat_v73_is_read_by_h5py_transposed_back(tmp_path):
    h5py = pytest.importorskip("h5py")
    se = _toy()
    f = tmp_path / "s73.mat"
    # what MATLAB's save -v7.3 writes: HDF5 with a 512-byte user block starting 'MATLAB 7.3', column-major
    with h5py.File(f, "w", userblock_size=512) as h:
        for k, v in S.to_dict(se).items():
            v = np.asarray(v)
            if v.dtype.kind == "U":
                if v.ndim == 0:
                    ds = h.create_dataset(k, data=np.array([ord(c) for c in str(v)], dtype=np.uint16)[:, None])
                    ds.attrs["MATLAB_class"] = np.bytes_("char")
                continue
            h.create_dataset(k, data=np.atleast_2d(v).T if v.ndim <= 2 else v.T)
    with open(f, "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file, created by a test".ljust(116))
    got = S.load(f)
    se_nonames = se.with_(sensor_names=("sensor0", "sensor1"), excitation_names=("excitation0",))  # names unnamed rows
    _same(se_nonames, got)


def test_matrix_market_round_trip(tmp_path):
    se = _toy(d=2)
    got = S.load(S.write_matrix_market(se, tmp_path / "mm"))
    _same(se, got)
    assert got.friction_dims == 1


def test_op4_round_trip(tmp_path):
    pytest.importorskip("pyNastran")
    se = _toy()
    got = S.load(S.write_op4(se, tmp_path / "s.op4"))
    _same(se.with_(sensor_names=("sensor0", "sensor1"), excitation_names=("excitation0",), u_rel_direction=None), got)


def test_mm_t_s_units_convert_to_si():
    """The same structure written in mm, tonne, s: frequencies unchanged, gaps and areas in SI."""
    se = _toy()
    d = S.to_dict(se)
    mm = {k: v for k, v in d.items()}
    for k in ("M", "K", "contact_rows", "f_bolts", "adaptive_row", "u_rel_row", "sensor_rows", "excitation"):
        mm[k] = d[k] * 1e3    # a row per unit q in mm is 1e3 x the row in m; energies in N mm are 1e3 x J
    mm["contact_area"] = d["contact_area"] * 1e6
    mm["adaptive_k"] = d["adaptive_k"] * 1e-3
    mm["units"] = "mm-t-s"
    _same(se, S.from_dict(mm), rtol=1e-15)


def test_brake_reuss_layout():
    """tmdsimpy's layout: two nodes' relative displacements (ux, uy, un) in L, one-point quadrature."""
    n = 7
    rng = np.random.default_rng(1)
    se0 = _toy(n=n)
    L = np.vstack([np.eye(6, n), rng.standard_normal((2, n))])     # 2 interface nodes, then other rows
    Qm = np.array([[0.5, 0.5]])                                     # 1 quadrature point between them
    a = 3e-4
    Tm = Qm.T * a
    d = {"M": se0.M, "K": se0.K, "L": L, "Qm": Qm, "Tm": Tm, "Fv": np.ones((n, 1)), "R": rng.standard_normal((3, n))}
    se = S.read_brake_reuss(d, preload_n=1000.0, sensor_index=2)
    assert se.contact_area == pytest.approx([a])
    u = 0.5 * (L[0:3] + L[3:6])           # the point's (ux, uy, un)
    np.testing.assert_allclose(se.contact_rows[0], np.vstack([-u[2], u[0], u[1]]))
    np.testing.assert_allclose(se.f_bolts, 1000.0 * np.ones(n))
    np.testing.assert_array_equal(se.excitation[0], d["R"][2])


BAD = [
    ("K", lambda d: d.update(K=d["K"] + np.triu(np.ones_like(d["K"]), 1)), "K: is not symmetric"),
    ("M", lambda d: d.update(M=d["M"][:-1, :-1]), "M: has shape (7, 7) but K has (8, 8)"),
    ("contact_rows", lambda d: d.update(contact_rows=d["contact_rows"][:, :, :-1]), "contact_rows: must have shape"),
    ("contact_area", lambda d: d["contact_area"].__setitem__(1, 0.0), "contact_area: point 1 has area 0.0"),
    ("contact_area", lambda d: d.update(contact_area=d["contact_area"][:2]), "contact_area: must have one area"),
    ("M", lambda d: d["M"].__setitem__((2, 2), -1.0), "M: negative mass -1 on diagonal entry 2"),
    ("units", lambda d: d.update(units="in-lbf-s"), "units: 'in-lbf-s' is not one of"),
    ("K", lambda d: d.pop("K"), "K: is missing"),
    ("u_rel_direction", lambda d: d.update(u_rel_direction=np.array([1.0, 1.0, 0.0])), "must be unit vectors"),
]


@pytest.mark.parametrize("entry,spoil,msg", BAD, ids=[b[2].split(":")[0] + str(i) for i, b in enumerate(BAD)])
def test_bad_input_is_one_line_naming_the_entry(entry, spoil, msg):
    d = {k: (np.array(v, copy=True) if isinstance(v, np.ndarray) else v) for k, v in S.to_dict(_toy()).items()}
    spoil(d)
    with pytest.raises(S.SuperelementError) as e:
        S.from_dict(d)
    text = str(e.value)
    assert "\n" not in text and text.startswith(entry + ":") and msg in text, text


def test_unknown_suffix_and_missing_file(tmp_path):
    with pytest.raises(S.SuperelementError, match="no such file"):
        S.load(tmp_path / "none.npz")
    (tmp_path / "x.bdf").write_text("")
    with pytest.raises(S.SuperelementError, match="unknown suffix '.bdf'"):
        S.load(tmp_path / "x.bdf")


def test_coarsen_keeps_the_area_and_averages_the_rows():
    """Node clustering: each cluster's area is its points' sum and its gap rows their area-weighted
    mean, so a uniform gap field (every point's rows equal) is carried unchanged."""
    se = _toy(p=12)
    rng = np.random.default_rng(5)
    xyz = np.column_stack([np.repeat(np.arange(4) * 0.01, 3), np.tile([-0.01, 0.0, 0.01], 4), np.zeros(12)])
    area = rng.uniform(1e-4, 3e-4, 12)
    rows = np.broadcast_to(se.contact_rows[:1], se.contact_rows.shape).copy()
    se = se.with_(contact_xyz=xyz, contact_area=area, contact_rows=rows)
    c = S.coarsen(se, 4)
    assert c.n_points == 4 and c.contact_area.sum() == pytest.approx(area.sum(), rel=1e-14)
    np.testing.assert_allclose(c.contact_rows, np.broadcast_to(rows[:1], (4, *rows.shape[1:])), rtol=1e-13)
    with pytest.raises(S.SuperelementError, match="clusters: 13 must lie in 1 .. 12"):
        S.coarsen(se, 13)
