"""A reduced structure from any FE code: the superelement format and its readers (docs/superelement.md).

A superelement is a linear structure in reduced coordinates q (Craig-Bampton or any reduction)

    M q'' + C q' + K q = f_bolts + a_exc F_exc - r_b F_b + sum_i R_i^T lambda_i

with its interface as linear maps from q to each contact point's local gaps,

    [g_n, g_t1, g_t2]_i = R_i q + [g0_i, 0, 0]       (rows 'contact_rows', (p, d, n); d = 2 or 3)

g_n > 0 open; g_t1, g_t2 the slips along two orthonormal directions of the contact plane (d = 2:
one direction, the 2-D joint). lambda_i is the point's force on the structure in the same local
directions, with the spec's laws per unit area times the point's area a_i (``contact_area``).
The adaptive bolt acts on the separation s = r_b q (``adaptive_row``, [m], positive apart) with
the force F_b = F_N1 + k_b (s - s_ref) (``adaptive_k`` [N/m]); the observer's scalar
u_rel = r_u q (``u_rel_row``), the relative tangential displacement at the adaptive bolt along
the direction ``u_rel_direction``.

On disk (.npz, ``save`` / ``load``; the same names in a .mat file, v5 or v7.3):

    M, K           (n, n)    mass, stiffness                   [kg, N/m in SI; see units]
    C              (n, n)    damping, optional                 [N s/m]
    contact_rows   (p, d, n) q -> (g_n, g_t1[, g_t2]) per point [m per unit q]
    contact_area   (p,)      area each point stands for         [m^2]
    contact_gap0   (p,)      normal gap at q = 0, optional      [m]
    contact_xyz    (p, 3)    coordinates, optional (plots)      [m]
    contact_normal (p, 3)    unit normal, optional (plots)      [-]
    f_bolts        (n,)      the ordinary bolts' preloads as a generalised force, optional [N]
    adaptive_row   (n,)      separation at the adaptive bolt, optional [m per unit q]
    adaptive_k     ()        adaptive bolt's axial stiffness (stack in series with the screw) [N/m]
    u_rel_row      (n,)      u_rel at the adaptive bolt         [m per unit q]
    u_rel_direction (3,)     the direction u_rel is measured along, optional [-]
    sensor_rows    (s, n)    sensor displacement rows           [m per unit q]
    sensor_names   (s,)      str
    excitation     (e, n)    generalised force per newton of each excitation [-]
    excitation_names (e,)    str
    units          str       "SI" (m, kg, s, N) or "mm-t-s" (mm, tonne, s, N: Abaqus/Nastran practice)

Units: "mm-t-s" is converted on reading (lengths x 1e-3; M, K, C, force vectors per unit q
x 1e-3: energies in N mm; areas x 1e-6; adaptive_k x 1e3), so every array held in memory is SI.

Length: the format, its checks and its readers are one contract (each reader ends in the same
``from_dict`` and ``check``); the readers are short and share the names table.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

FORMAT_VERSION = 1
UNIT_SYSTEMS = ("SI", "mm-t-s")
SYMMETRY_RTOL = 1e-8   # |K - K^T| <= rtol |K|_max: a symmetric matrix written in text to 1e-9 relative passes
OPTIONAL_FE_HINT = "pip install 'frictionrt[fe]'"


class SuperelementError(ValueError):
    """Bad superelement input: the message is one line naming the entry and the fix."""


@dataclass(frozen=True)
class Superelement:
    """A reduced structure (module docstring); SI units; validated by ``check``."""
    M: np.ndarray
    K: np.ndarray
    contact_rows: np.ndarray
    contact_area: np.ndarray
    C: np.ndarray | None = None
    contact_gap0: np.ndarray | None = None
    contact_xyz: np.ndarray | None = None
    contact_normal: np.ndarray | None = None
    f_bolts: np.ndarray | None = None
    adaptive_row: np.ndarray | None = None
    adaptive_k: float = 0.0
    u_rel_row: np.ndarray | None = None
    u_rel_direction: np.ndarray | None = None
    sensor_rows: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    sensor_names: tuple[str, ...] = ()
    excitation: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    excitation_names: tuple[str, ...] = ()
    source: str = ""

    @property
    def n(self) -> int:
        return self.K.shape[0]

    @property
    def n_points(self) -> int:
        return self.contact_rows.shape[0]

    @property
    def friction_dims(self) -> int:
        """Tangential directions per contact point: 1 (2-D joint) or 2 (3-D, circular Coulomb)."""
        return self.contact_rows.shape[1] - 1

    def with_(self, **kw) -> "Superelement":
        return replace(self, **kw)


ARRAY_KEYS = ("M", "K", "C", "contact_rows", "contact_area", "contact_gap0", "contact_xyz", "contact_normal",
              "f_bolts", "adaptive_row", "u_rel_row", "u_rel_direction", "sensor_rows", "excitation")


def _fail(entry: str, msg: str) -> SuperelementError:
    return SuperelementError(f"{entry}: {msg}")


def check(se: Superelement) -> Superelement:
    """Refuse an inconsistent superelement with a one-line SuperelementError naming the entry:
    non-square, non-symmetric or non-finite M, K, C; a mass matrix with a negative diagonal entry
    or a negative eigenvalue; mismatched sizes; a contact point without area; a direction that is
    not a unit vector. Returns se."""
    n = se.K.shape[0] if se.K.ndim == 2 else -1
    for name in ("M", "K", "C"):
        A = getattr(se, name)
        if A is None:
            continue
        if A.ndim != 2 or A.shape[0] != A.shape[1]:
            raise _fail(name, f"must be a square matrix, got shape {A.shape}")
        if A.shape != (n, n):
            raise _fail(name, f"has shape {A.shape} but K has {(n, n)}: give all matrices on the same reduced DOFs")
        if not np.all(np.isfinite(A)):
            i, j = np.argwhere(~np.isfinite(A))[0]
            raise _fail(name, f"entry ({i}, {j}) is {A[i, j]}: the matrix must be finite")
        asym = np.abs(A - A.T)
        scale = max(np.abs(A).max(), np.finfo(float).tiny)
        if asym.max() > SYMMETRY_RTOL * scale:
            i, j = np.unravel_index(np.argmax(asym), asym.shape)
            raise _fail(name, f"is not symmetric: ({i}, {j}) = {A[i, j]:.6g} but ({j}, {i}) = {A[j, i]:.6g}; "
                              "export the symmetric matrix (not a triangle or an unsymmetric solver's)")
    d = np.diag(se.M)
    if (d < 0).any():
        i = int(np.argmin(d))
        raise _fail("M", f"negative mass {d[i]:.6g} on diagonal entry {i}: check the units and the export")
    lam_min = np.linalg.eigvalsh(0.5 * (se.M + se.M.T))[0]
    if lam_min < -1e-10 * max(d.max(), 1e-300):
        raise _fail("M", f"is not positive semi-definite (smallest eigenvalue {lam_min:.3g}): a negative mass")
    R = se.contact_rows
    if R.ndim != 3 or R.shape[1] not in (2, 3) or R.shape[2] != n:
        raise _fail("contact_rows", f"must have shape (points, 2 or 3, {n}) (g_n, g_t1[, g_t2] per point), "
                                    f"got {R.shape}")
    p = R.shape[0]
    if p == 0:
        raise _fail("contact_rows", "has no contact points: a structure without an interface needs no superelement")
    a = se.contact_area
    if a.shape != (p,):
        raise _fail("contact_area", f"must have one area per contact point ({p},), got {a.shape}")
    bad = np.flatnonzero(~(a > 0) | ~np.isfinite(a))
    if len(bad):
        raise _fail("contact_area", f"point {bad[0]} has area {float(a[bad[0]])!r} m^2: every contact point must "
                                    "carry a positive area (its share of the interface)")
    for name, shape in (("contact_gap0", (p,)), ("contact_xyz", (p, 3)), ("contact_normal", (p, 3)),
                        ("f_bolts", (n,)), ("adaptive_row", (n,)), ("u_rel_row", (n,)), ("u_rel_direction", (3,))):
        v = getattr(se, name)
        if v is not None and v.shape != shape:
            raise _fail(name, f"must have shape {shape}, got {v.shape}")
        if v is not None and not np.all(np.isfinite(v)):
            raise _fail(name, "must be finite")
    for name in ("contact_normal", "u_rel_direction"):
        v = getattr(se, name)
        if v is not None:
            nv = np.linalg.norm(np.atleast_2d(v), axis=1)
            if np.any(np.abs(nv - 1.0) > 1e-6):
                raise _fail(name, f"must be unit vectors, got length {nv[np.argmax(np.abs(nv - 1))]:.6g}")
    if se.adaptive_row is not None and not (se.adaptive_k >= 0.0 and np.isfinite(se.adaptive_k)):
        raise _fail("adaptive_k", f"must be a stiffness >= 0 N/m, got {se.adaptive_k!r}")
    for rows, names, label in ((se.sensor_rows, se.sensor_names, "sensor"),
                               (se.excitation, se.excitation_names, "excitation")):
        key = "sensor_rows" if label == "sensor" else "excitation"
        if rows.size and (rows.ndim != 2 or rows.shape[1] != n):
            raise _fail(key, f"must have shape ({label}s, {n}), got {rows.shape}")
        if rows.size and len(names) != rows.shape[0]:
            raise _fail(f"{label}_names", f"has {len(names)} names for {rows.shape[0]} rows of {key}")
    return se


def _convert_units(d: dict, units: str) -> dict:
    if units == "SI":
        return d
    if units != "mm-t-s":
        raise _fail("units", f"{units!r} is not one of {UNIT_SYSTEMS}")
    L = 1e-3
    out = dict(d)
    for k in ("M", "K", "C", "contact_rows", "contact_gap0", "contact_xyz", "f_bolts", "adaptive_row",
              "u_rel_row", "sensor_rows", "excitation"):
        if out.get(k) is not None:
            out[k] = out[k] * L
    if out.get("contact_area") is not None:
        out["contact_area"] = out["contact_area"] * L * L
    if out.get("adaptive_k") is not None:
        out["adaptive_k"] = out["adaptive_k"] / L
    return out


def _str_tuple(v) -> tuple[str, ...]:
    if v is None:
        return ()
    a = np.atleast_1d(np.asarray(v))
    return tuple(str(s).strip() for s in a.ravel())


def from_dict(d: dict, source: str = "") -> Superelement:
    """A checked Superelement from a mapping of the on-disk names (module docstring); the unit
    system in d["units"] (default "SI") is converted to SI."""
    for k in ("M", "K", "contact_rows", "contact_area"):
        if d.get(k) is None:
            raise _fail(k, f"is missing in {source or 'the input'}: a superelement needs M, K, contact_rows and "
                           "contact_area (docs/superelement.md)")
    units = "SI" if d.get("units") is None else str(np.asarray(d["units"]).ravel()[0]).strip()
    arr = {}
    for k in ARRAY_KEYS:
        v = d.get(k)
        if v is None:
            continue
        try:
            arr[k] = np.array(_dense(v), dtype=np.float64)
        except (TypeError, ValueError):
            raise _fail(k, "is not numeric") from None
    if "contact_area" in arr:
        arr["contact_area"] = arr["contact_area"].ravel()
    for k in ("contact_gap0", "f_bolts", "adaptive_row", "u_rel_row", "u_rel_direction"):
        if k in arr:
            arr[k] = arr[k].ravel()
    for k in ("sensor_rows", "excitation"):
        if k in arr:
            arr[k] = np.atleast_2d(arr[k])
    if d.get("adaptive_k") is not None:
        arr["adaptive_k"] = float(np.asarray(d["adaptive_k"]).ravel()[0])
    arr = _convert_units(arr, units)
    ns = arr["sensor_rows"].shape[0] if "sensor_rows" in arr else 0
    ne = arr["excitation"].shape[0] if "excitation" in arr else 0
    sensor_names = _str_tuple(d.get("sensor_names")) or tuple(f"sensor{i}" for i in range(ns))
    excitation_names = _str_tuple(d.get("excitation_names")) or tuple(f"excitation{i}" for i in range(ne))
    se = Superelement(
        M=arr["M"], K=arr["K"], contact_rows=arr["contact_rows"], contact_area=arr["contact_area"],
        C=arr.get("C"), contact_gap0=arr.get("contact_gap0"), contact_xyz=arr.get("contact_xyz"),
        contact_normal=arr.get("contact_normal"), f_bolts=arr.get("f_bolts"), adaptive_row=arr.get("adaptive_row"),
        adaptive_k=arr.get("adaptive_k", 0.0), u_rel_row=arr.get("u_rel_row"),
        u_rel_direction=arr.get("u_rel_direction"),
        sensor_rows=arr.get("sensor_rows", np.zeros((0, arr["K"].shape[0] if arr["K"].ndim == 2 else 0))),
        sensor_names=sensor_names,
        excitation=arr.get("excitation", np.zeros((0, arr["K"].shape[0] if arr["K"].ndim == 2 else 0))),
        excitation_names=excitation_names, source=source)
    return check(se)


def _dense(v):
    return v.toarray() if hasattr(v, "toarray") else v


def to_dict(se: Superelement) -> dict:
    """The on-disk names (SI) of se: the inverse of ``from_dict``."""
    d = {k: getattr(se, k) for k in ARRAY_KEYS if getattr(se, k) is not None}
    d.update(adaptive_k=np.float64(se.adaptive_k), units="SI", format_version=np.int64(FORMAT_VERSION),
             sensor_names=np.array(se.sensor_names, dtype=str), excitation_names=np.array(se.excitation_names, dtype=str))
    return d


def save(se: Superelement, path: str | Path) -> Path:
    """Write se as a .npz file (atomically: a temporary file renamed)."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez(tmp, **to_dict(check(se)))
    tmp.replace(path)
    return path


def load(path: str | Path, **kw) -> Superelement:
    """Read a superelement: .npz (this format), .mat (v5 by scipy, v7.3 by h5py; this format's
    names or tmdsimpy's Brake-Reuss layout M, K, L, Qm, Tm, Fv, R: ``read_brake_reuss``), .json
    naming Matrix Market files (``read_matrix_market``), .op4 (``read_op4``). Keyword arguments
    go to the layout's reader. SuperelementError (one line) on bad input."""
    path = Path(path)
    if not path.exists():
        raise _fail(str(path), "no such file")
    suf = path.suffix.lower()
    if suf == ".npz":
        with np.load(path, allow_pickle=False) as z:
            d = {k: z[k] for k in z.files}
        v = int(d.pop("format_version", FORMAT_VERSION))
        if v > FORMAT_VERSION:
            raise _fail("format_version", f"{v} is newer than this reader's {FORMAT_VERSION}: update frictionrt")
        return from_dict(d, source=str(path))
    if suf == ".mat":
        d = read_mat(path)
        if "contact_rows" not in d and "Qm" in d:
            return read_brake_reuss(d, source=str(path), **kw)
        return from_dict(d, source=str(path))
    if suf == ".json":
        return read_matrix_market(path)
    if suf == ".op4":
        return read_op4(path, **kw)
    raise _fail(str(path), f"unknown suffix {suf!r}: give .npz, .mat, .json (Matrix Market manifest) or .op4")


# --- readers ---------------------------------------------------------------------------------

def read_mat(path: str | Path) -> dict:
    """The variables of a MATLAB .mat file as a dict of arrays: v4-v7 by scipy.io.loadmat; v7.3
    (HDF5) by h5py (optional extra [fe]), whose column-major arrays are transposed back; sparse
    matrices (MATLAB's jc/ir/data groups) are densified."""
    import scipy.io as sio
    path = Path(path)
    with open(path, "rb") as f:
        head = f.read(128)
    if b"MATLAB 7.3" not in head and not head.startswith(b"\x89HDF"):
        try:
            raw = sio.loadmat(path, squeeze_me=False, chars_as_strings=True)
        except Exception as e:  # scipy raises several types on a damaged file
            raise _fail(str(path), f"not a readable MATLAB file ({type(e).__name__}: {e})") from None
        return {k: _dense(v) if not isinstance(v, np.ndarray) or v.dtype.kind != "U" else v
                for k, v in raw.items() if not k.startswith("__")}
    try:
        import h5py
    except ImportError:
        raise _fail(str(path), f"is a MATLAB v7.3 (HDF5) file and h5py is not installed: {OPTIONAL_FE_HINT}") from None
    out = {}
    with h5py.File(path, "r") as f:
        for k in f.keys():
            if k.startswith("#"):
                continue
            obj = f[k]
            cls = obj.attrs.get("MATLAB_class", b"double")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            if isinstance(obj, h5py.Group) and "jc" in obj:       # sparse: CSC of the MATLAB matrix
                import scipy.sparse as sp
                nrows = int(obj.attrs["MATLAB_sparse"])
                jc, ir, data = obj["jc"][()], obj["ir"][()], obj["data"][()]
                out[k] = sp.csc_matrix((data, ir, jc), shape=(nrows, len(jc) - 1)).toarray()
            elif isinstance(obj, h5py.Dataset):
                v = obj[()]
                if cls == "char":
                    out[k] = np.array("".join(chr(c) for c in np.asarray(v).ravel()))
                else:
                    out[k] = np.asarray(v).T
    return out


def read_brake_reuss(d: dict, source: str = "", preload_n: float = 0.0, sensor_index: int | None = None,
                     normal_sign: float = 1.0) -> Superelement:
    """tmdsimpy's Brake-Reuss layout: M, K (n, n); L (>= 3 N_nodes, n) the interface nodes' relative
    displacements (ux, uy, un per node) from the reduced DOFs; Qm (N_q, N_nodes) nodes -> quadrature
    points; Tm (N_nodes, N_q) tractions -> nodal forces (area weights); Fv (n, 1) the bolts'
    preload per newton of bolt force; R (s, n) recovery rows (sensors).

    Each quadrature point becomes a contact point with rows Qm_i (x) I_3 L, reordered to (g_n, g_t1,
    g_t2) = (-normal_sign un, ux, uy): tmdsimpy's un is the closure (positive in contact), the gap
    its negative; area a_i = sum_k Tm[k, i], which requires Tm = Qm^T diag(a) (a Galerkin
    quadrature; refused otherwise). preload_n [N] per bolt: f_bolts = preload_n Fv. The sensors are
    R's rows; sensor_index picks the row that is also the excitation (tmdsimpy's examples excite at
    the accelerometer, R[2])."""
    for k in ("M", "K", "L", "Qm", "Tm"):
        if d.get(k) is None:
            raise _fail(k, f"is missing in {source or 'the input'}: the Brake-Reuss layout needs M, K, L, Qm, Tm "
                           "(and optionally Fv, R)")
    M, K, L = (np.asarray(_dense(d[k]), dtype=float) for k in ("M", "K", "L"))
    Qm, Tm = (np.asarray(_dense(d[k]), dtype=float) for k in ("Qm", "Tm"))
    nq, nn = Qm.shape
    if Tm.shape != (nn, nq):
        raise _fail("Tm", f"must have shape (nodes, quadrature points) = {(nn, nq)} to match Qm {Qm.shape}, "
                          f"got {Tm.shape}")
    if L.shape[0] < 3 * nn or L.shape[1] != K.shape[0]:
        raise _fail("L", f"must have at least 3 x {nn} rows (ux, uy, un per interface node) and {K.shape[0]} "
                         f"columns (K's DOFs), got {L.shape}")
    area = Tm.sum(axis=0)
    if np.any(area <= 0):
        i = int(np.argmin(area))
        raise _fail("Tm", f"quadrature point {i} has area {area[i]:.6g} m^2 (column sum): every point needs a "
                          "positive area")
    if not np.allclose(Tm, Qm.T * area, rtol=1e-8, atol=1e-12 * area.max()):
        raise _fail("Tm", "is not Qm^T diag(area) (a Galerkin one-point quadrature): this reader maps each "
                          "quadrature point to one contact point and needs that form")
    QL = np.kron(Qm, np.eye(3)) @ L[:3 * nn]
    rows = QL.reshape(nq, 3, -1)[:, [2, 0, 1], :].copy()
    rows[:, 0, :] *= -normal_sign
    Fv = d.get("Fv")
    f_bolts = None if Fv is None else preload_n * np.asarray(_dense(Fv), dtype=float).ravel()
    R = d.get("R")
    sensors = np.zeros((0, K.shape[0])) if R is None else np.atleast_2d(np.asarray(_dense(R), dtype=float))
    names = tuple(f"R{i}" for i in range(sensors.shape[0]))
    exc = sensors[[sensor_index]] if sensor_index is not None else np.zeros((0, K.shape[0]))
    return check(Superelement(M=M, K=K, contact_rows=rows, contact_area=area, f_bolts=f_bolts,
                              sensor_rows=sensors, sensor_names=names, excitation=exc,
                              excitation_names=(names[sensor_index],) if sensor_index is not None else (),
                              source=source))


def read_matrix_market(manifest: str | Path) -> Superelement:
    """A superelement from Matrix Market files (scipy.io.mmread): a JSON manifest maps the
    on-disk names to .mtx files beside it (or to numbers / lists for the small entries):
    {"units": "SI", "M": "M.mtx", "K": "K.mtx", "contact_rows": "rows.mtx", "contact_dims": 3,
    "contact_area": "area.mtx", ...}. contact_rows is stored as a (p d, n) matrix (rows
    g_n, g_t1[, g_t2] of each point in turn) with contact_dims = d."""
    import scipy.io as sio
    manifest = Path(manifest)
    try:
        spec = json.loads(manifest.read_text())
    except json.JSONDecodeError as e:
        raise _fail(str(manifest), f"is not JSON ({e.msg}, line {e.lineno})") from None
    d = {}
    for k, v in spec.items():
        if isinstance(v, str) and v.lower().endswith(".mtx"):
            f = manifest.parent / v
            if not f.exists():
                raise _fail(k, f"names {v}, which does not exist beside {manifest.name}")
            d[k] = np.asarray(_dense(sio.mmread(f)), dtype=float)
        else:
            d[k] = np.asarray(v)
    dims = int(spec.get("contact_dims", 3))
    if d.get("contact_rows") is not None:
        R = d["contact_rows"]
        if R.ndim != 2 or R.shape[0] % dims:
            raise _fail("contact_rows", f"must be a (points x {dims}, n) matrix for contact_dims = {dims}, got {R.shape}")
        d["contact_rows"] = R.reshape(R.shape[0] // dims, dims, R.shape[1])
    d.pop("contact_dims", None)
    return from_dict(d, source=str(manifest))


def write_matrix_market(se: Superelement, folder: str | Path) -> Path:
    """Write se as Matrix Market files and their manifest folder/superelement.json (the reader's input)."""
    import scipy.io as sio
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    spec: dict = {"units": "SI", "contact_dims": se.contact_rows.shape[1]}
    for k in ARRAY_KEYS:
        v = getattr(se, k)
        if v is None or (isinstance(v, np.ndarray) and v.size == 0):
            continue
        if k == "contact_rows":
            v = v.reshape(-1, v.shape[2])
        sio.mmwrite(folder / f"{k}.mtx", np.atleast_2d(v), precision=17)
        spec[k] = f"{k}.mtx"
    spec.update(adaptive_k=se.adaptive_k, sensor_names=list(se.sensor_names),
                excitation_names=list(se.excitation_names))
    out = folder / "superelement.json"
    out.write_text(json.dumps(spec, indent=1))
    return out


def read_op4(path: str | Path, contact_dims: int = 3, units: str = "SI") -> Superelement:
    """A superelement from a Nastran OP4 file (pyNastran, optional extra [fe]): matrices named
    MAA (or M), KAA (or K), optionally BAA (or C), and the interface and load matrices under this
    format's names in upper case (CONTACT_ROWS as (p d, n), CONTACT_AREA, F_BOLTS, ADAPTIVE_ROW,
    U_REL_ROW, SENSOR_ROWS, EXCITATION; ADAPTIVE_K as 1 x 1). OP4 names have at most 8 characters
    in some writers: the short names CROWS, CAREA, FBOLT, ADROW, ADK, UREL, SENS, EXC are read too."""
    try:
        from pyNastran.op4.op4 import read_op4 as _read
    except ImportError:
        raise _fail(str(path), f"reading OP4 needs pyNastran, which is not installed: {OPTIONAL_FE_HINT}") from None
    try:
        mats = _read(str(path), debug=False)
    except Exception as e:
        raise _fail(str(path), f"not a readable OP4 file ({type(e).__name__}: {e})") from None
    got = {k.strip().upper(): _dense(v[1] if isinstance(v, tuple) else getattr(v, "data", v)) for k, v in mats.items()}
    alias = {"M": ("MAA", "M"), "K": ("KAA", "K"), "C": ("BAA", "C"), "contact_rows": ("CONTACT_ROWS", "CROWS"),
             "contact_area": ("CONTACT_AREA", "CAREA"), "contact_gap0": ("CONTACT_GAP0", "CGAP0"),
             "f_bolts": ("F_BOLTS", "FBOLT"), "adaptive_row": ("ADAPTIVE_ROW", "ADROW"),
             "adaptive_k": ("ADAPTIVE_K", "ADK"), "u_rel_row": ("U_REL_ROW", "UREL"),
             "sensor_rows": ("SENSOR_ROWS", "SENS"), "excitation": ("EXCITATION", "EXC")}
    d: dict = {"units": units}
    for k, names in alias.items():
        for nm in names:
            if nm in got:
                d[k] = np.asarray(got[nm], dtype=float)
                break
    R = d.get("contact_rows")
    if R is not None:
        if R.ndim != 2 or R.shape[0] % contact_dims:
            raise _fail("CONTACT_ROWS", f"must be a (points x {contact_dims}, n) matrix, got {R.shape}")
        d["contact_rows"] = R.reshape(R.shape[0] // contact_dims, contact_dims, R.shape[1])
    return from_dict(d, source=str(path))


def write_op4(se: Superelement, path: str | Path) -> Path:
    """Write se's matrices to a Nastran OP4 file (pyNastran) under the short names read_op4 reads."""
    from pyNastran.op4.op4 import OP4
    names = {"M": "MAA", "K": "KAA", "C": "BAA", "contact_rows": "CROWS", "contact_area": "CAREA",
             "contact_gap0": "CGAP0", "f_bolts": "FBOLT", "adaptive_row": "ADROW", "u_rel_row": "UREL",
             "sensor_rows": "SENS", "excitation": "EXC"}
    mats = {}
    for k, nm in names.items():
        v = getattr(se, k)
        if v is None or v.size == 0:
            continue
        if k == "contact_rows":
            v = v.reshape(-1, v.shape[2])
        v = np.atleast_2d(v)
        form = 6 if (v.shape[0] == v.shape[1] and np.array_equal(v, v.T)) else 2
        mats[nm] = (form, np.ascontiguousarray(v))
    if se.adaptive_row is not None:
        mats["ADK"] = (2, np.array([[se.adaptive_k]]))
    OP4().write_op4(str(path), mats, name_order=list(mats), precision="double", is_binary=False)
    return Path(path)


CLUSTERINGS = ("footprint", "coordinates", "footprint-patches")
DEFAULT_CLUSTERING = CLUSTERINGS[0]
"""How ``--clusters N`` groups the interface's points (``coarsen``): "footprint" keeps the bolts'
contact footprints apart (plant.se_coarsen.footprint_classes: which adaptive-bolt force closes each
point) and fills them first, "coordinates" is k-means on the coordinates alone, "footprint-patches"
the footprint groups with the normal stiffness that a coarse point loses on the patches the bolts
hold closed kept in K (plant.se_coarsen.patch_stiffness)."""


def footprint_regions(xyz: np.ndarray, classes: np.ndarray) -> np.ndarray:
    """Region label (0 .. r-1) of each point: the connected parts of each class. Two points of a
    class are connected when they are at most the interface's grid reach apart: the longest edge of
    the minimum spanning tree of all points (the largest single-linkage merge distance,
    scipy.cluster.hierarchy), so on a regular grid neighbours along the coarsest spacing connect.
    Labels ordered by (class, the region's mean coordinates)."""
    from scipy.cluster.hierarchy import fcluster, linkage
    p = len(xyz)
    if p == 1:
        return np.zeros(1, np.int64)
    reach = linkage(xyz, method="single")[-1, 2] * (1.0 + 1e-9)
    parts = []
    for c in np.unique(classes):
        idx = np.flatnonzero(classes == c)
        lab = np.ones(len(idx), np.int64) if len(idx) == 1 else \
            fcluster(linkage(xyz[idx], method="single"), t=reach, criterion="distance")
        for lb in np.unique(lab):
            g = idx[lab == lb]
            parts.append((int(c), tuple(xyz[g].mean(axis=0)), g))
    out = np.empty(p, np.int64)
    for r, (_, _, g) in enumerate(sorted(parts, key=lambda t: t[:2])):
        out[g] = r
    return out


def _allocate(sizes: np.ndarray, rank: np.ndarray, n: int) -> np.ndarray:
    """n >= len(sizes) groups over regions of sizes points: one each, then the rest to the regions of
    the lowest rank first (in proportion to their points, largest remainder, ties to the earlier
    region; never more groups than points), then the next rank."""
    k = np.ones(len(sizes), np.int64)
    left = n - len(sizes)
    for r in np.unique(rank):
        sel = np.flatnonzero(rank == r)
        while left > 0 and np.any(k[sel] < sizes[sel]):
            target = (k[sel].sum() + left) * sizes[sel] / sizes[sel].sum()
            share = np.where(k[sel] < sizes[sel], target - k[sel], -np.inf)
            k[sel[int(np.argmax(share))]] += 1
            left -= 1
    return k


def _footprint_groups(xyz: np.ndarray, classes: np.ndarray, n: int, seed: int) -> list[np.ndarray]:
    """Groups of ``coarsen`` with classes: the regions of ``footprint_regions``, the highest classes
    merged into one (from the top) until the regions take at most half of the n groups (the other
    half refines the lowest class, whose patches carry the bolts' moments), or until only class 0
    and the rest are left and their regions fit n (else one class: k-means over all points);
    ``_allocate``'s counts per region, k-means (fixed seed) within a region."""
    from scipy.cluster.vq import kmeans2
    for top in range(int(classes.max()), -1, -1):
        c = np.minimum(classes, top)
        region = footprint_regions(xyz, c)
        nr = int(region.max()) + 1
        if nr <= n / 2 or (top <= 1 and nr <= n):
            break
    sizes = np.bincount(region, minlength=nr)
    rank = np.array([c[region == r][0] for r in range(nr)])
    groups = []
    for r, k in enumerate(_allocate(sizes, rank, n)):
        idx = np.flatnonzero(region == r)
        if k == len(idx):
            groups += [idx[[i]] for i in range(len(idx))]
        elif k == 1:
            groups.append(idx)
        else:
            _, lab = kmeans2(xyz[idx], int(k), minit="++", seed=seed)
            groups += [idx[lab == j] for j in range(int(k))]
    return groups


def coarsen_weights(se: Superelement, n_clusters: int, seed: int = 0, classes: np.ndarray | None = None) -> np.ndarray:
    """The grouping of ``coarsen`` as its map W (c, p): W[c, i] = a_i / A_c for the points i of group
    c (A_c the group's area), 0 elsewhere; the groups ordered by their mean coordinates."""
    from scipy.cluster.vq import kmeans2
    p = se.n_points
    if not 1 <= n_clusters <= p:
        raise _fail("clusters", f"{n_clusters} must lie in 1 .. {p} (the interface's points)")
    if se.contact_xyz is None:
        raise _fail("contact_xyz", "is needed to coarsen the interface (the points' coordinates)")
    xyz = se.contact_xyz
    if n_clusters == p:
        groups = [np.array([i]) for i in range(p)]
    elif classes is None:
        _, label = kmeans2(xyz, n_clusters, minit="++", seed=seed)
        groups = [np.flatnonzero(label == c) for c in range(n_clusters)]
    else:
        groups = _footprint_groups(xyz, np.asarray(classes, np.int64), n_clusters, seed)
    groups = sorted((g for g in groups if len(g)), key=lambda g: tuple(xyz[g].mean(axis=0)))
    a = se.contact_area
    W = np.zeros((len(groups), p))
    for c, g in enumerate(groups):
        W[c, g] = a[g] / a[g].sum()
    return W


def coarsen(se: Superelement, n_clusters: int, seed: int = 0, classes: np.ndarray | None = None) -> Superelement:
    """The interface coarsened to n_clusters contact points (a node-clustering hyper-reduction),
    each group replaced by one point with the group's total area and its area-weighted mean gap
    rows, coordinates, normal and initial gap. The stuck stiffness of a group (k per area x total
    area, acting on the mean gaps) is the group's as long as the group moves as a rigid patch; the
    error against the fine interface is a reported figure (docs/superelement.md).

    Grouping: classes None, k-means on the coordinates (scipy.cluster.vq.kmeans2, fixed seed).
    With classes (an int per point, the lower the more important: the bolts' footprints,
    plant.se_coarsen.footprint_classes), no group mixes two classes or two separate regions of one
    class (``footprint_regions``; the highest classes merged while their regions would take more
    than half of the groups, ``_footprint_groups``): each region gets one group, the remaining
    groups go to the regions of the lowest class first, in proportion to their points, and k-means
    splits a region into its groups.
    """
    p = se.n_points
    if not 1 <= n_clusters <= p:
        raise _fail("clusters", f"{n_clusters} must lie in 1 .. {p} (the interface's points)")
    if n_clusters == p:
        return se
    W = coarsen_weights(se, n_clusters, seed, classes)
    a = se.contact_area
    normal = None
    if se.contact_normal is not None:
        normal = W @ se.contact_normal
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    how = "" if classes is None else " by the bolts' footprints"
    return check(replace(se, contact_rows=np.einsum("cp,pdn->cdn", W, se.contact_rows),
                         contact_area=np.array([a[np.flatnonzero(w)].sum() for w in W]),
                         contact_gap0=None if se.contact_gap0 is None else W @ se.contact_gap0,
                         contact_xyz=W @ se.contact_xyz, contact_normal=normal,
                         source=f"{se.source} coarsened to {len(W)} points{how}"))
