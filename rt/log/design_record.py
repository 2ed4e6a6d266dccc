"""A run's design-time numbers carried in its log, so that a replay on another machine uses the same ones.

Design time (FE assembly, ``eigh`` and Craig-Bampton, the static preload equilibrium,
``control.dlqe``, ``expm``, filter design) runs on numpy's and scipy's BLAS and LAPACK, which
choose their kernels per CPU (OpenBLAS: Haswell, SkylakeX, Zen, ...), and on the C library's
libm: two machines build the same configuration into arrays that differ in the last bits
(measured: ``OPENBLAS_CORETYPE=Prescott`` on this machine moves the controller's replay by
1.4e-5 from tick 1, docs/determinism.md). The run-time kernels are then fed different numbers,
and a rattling contact amplifies them. A replay that rebuilt the model from the logged
configuration would therefore be bit-exact only on the machine that wrote the log.

So ``simulate --out`` stores what the compiled loop reads, as the MCAP attachment
``DESIGN_ATTACHMENT`` (an .npz that ``numpy.load`` opens):

    params.<part>.<field>   every field of the kernels' parameter tuples (``PARTS``), nested
                            tuples as <field>.<subfield>; numbers as 0-d arrays of their type.
                            A part in ``OPTIONAL`` is stored only when its kernel runs (the
                            amplitude-following observer's tables, ``params.amplitude.*``, for
                            ``--estimator amplitude``), so a log of another kind has the same bytes
    state.<slot>            the initial loop state's arrays (``STATE``: the static preload
                            equilibrium of the plant, every filter's rest state)

and ``replay`` / ``replay --plant`` put them into the loop they rebuild (``apply``), after
comparing (``compare``): the replay reports whether this machine's build is identical and
by how much it differs. With ``--set`` overrides the replay runs the rebuilt model (the point of
the override). A log without the attachment (older logs, measurements) replays the rebuilt
model. A log that lacks an optional part its kind runs (an amplitude-kind log written before its
tables were stored) takes the rest from the log and rebuilds that part from its configuration, and
the report's "why" says so (``rebuilt_parts``). The archive is byte-deterministic (fixed member order
and time stamps), so the same run writes the same bytes.
"""
from __future__ import annotations

import dataclasses
import io
import zipfile

import numpy as np

DESIGN_ATTACHMENT = "frictionrt/design.npz"
MEDIA_TYPE = "application/x-npz"
# (part, attribute path on the Loop) of every parameter tuple a compiled stage reads
PARTS = (("plant", "plant.params"), ("actuator", "actuator"), ("sensors", "sensors"), ("oracle", "oracle"),
         ("observer", "observer"), ("prefilter", "prefilter"), ("law", "law_params"),
         ("tracking", "design.params"), ("supervisor", "supervisor"), ("shaker", "shaker"),
         ("amplitude", "amplitude"))
# parts stored only when their kernel runs: part -> the field whose size 0 (or a None part) says it does not
OPTIONAL = {"amplitude": "grid"}
# the initial-state slots of rt.loop.build.LoopState each part owns
STATE = {"plant": ("xp", "yp"), "actuator": ("xa", "ya"), "sensors": ("xs", "ys"), "oracle": ("xo",),
         "observer": ("xe",), "law": ("xl", "yl"), "prefilter": ("xq",), "tracking": ("xf", "yf"),
         "supervisor": ("sv",), "shaker": ("xsh",), "amplitude": ()}
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)


def _get(obj, path: str):
    for name in path.split("."):
        obj = getattr(obj, name)
    return obj


def _flatten(prefix: str, tup, out: dict[str, np.ndarray]) -> None:
    for name, v in zip(tup._fields, tup):
        key = f"{prefix}.{name}"
        if hasattr(v, "_fields"):
            _flatten(key, v, out)
        else:
            out[key] = np.array(v)   # a copy; 0-d for numbers (bool, int64, float64 kept)


def runs(loop, part: str) -> bool:
    """Whether ``part``'s kernel runs in ``loop``: always for a part not in ``OPTIONAL``; for an
    optional one, whether its parameters exist and are not of size 0."""
    if part not in OPTIONAL:
        return True
    tup = _get(loop, dict(PARTS)[part])
    return tup is not None and np.size(getattr(tup, OPTIONAL[part])) > 0


def design_arrays(loop, state) -> dict[str, np.ndarray]:
    """Every parameter the loop's kernels read and the initial state's arrays (module docstring)."""
    out: dict[str, np.ndarray] = {}
    for part, path in PARTS:
        if runs(loop, part):
            _flatten(f"params.{part}", _get(loop, path), out)
    for slots in STATE.values():
        for slot in slots:
            out[f"state.{slot}"] = np.array(getattr(state, slot))
    return out


def to_npz(arrays: dict[str, np.ndarray]) -> bytes:
    """The arrays as an .npz archive with fixed member order and time stamps (same bytes per run)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for key in sorted(arrays):
            member = io.BytesIO()
            np.lib.format.write_array(member, np.array(arrays[key], order="C"), allow_pickle=False)
            z.writestr(zipfile.ZipInfo(key + ".npy", date_time=_ZIP_TIME), member.getvalue(),
                       compress_type=zipfile.ZIP_DEFLATED)
    return buf.getvalue()


def from_npz(data: bytes) -> dict[str, np.ndarray]:
    """The arrays of ``to_npz``; ValueError if the archive is unreadable."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise ValueError(f"the attachment {DESIGN_ATTACHMENT} is unreadable ({exc})") from None


def _rebuilt(tup, prefix: str, logged: dict[str, np.ndarray]):
    """tup with every field replaced by the logged one (same type, shape and dtype), or KeyError /
    TypeError naming the first field that does not fit. A number the log lacks is kept where it
    equals its field's declared default (a field added to a kernel's parameters with the value that
    keeps the earlier kernel's behaviour, e.g. the plant's step scheme)."""
    values = {}
    defaults = getattr(tup, "_field_defaults", {})
    for name, v in zip(tup._fields, tup):
        key = f"{prefix}.{name}"
        if hasattr(v, "_fields"):
            values[name] = _rebuilt(v, key, logged)
            continue
        if key not in logged and name in defaults and not isinstance(v, np.ndarray) and v == defaults[name]:
            continue
        a = logged[key]
        if isinstance(v, np.ndarray):
            if a.shape != v.shape or a.dtype != v.dtype:
                raise TypeError(f"{key}: logged {a.dtype}{list(a.shape)}, this model {v.dtype}{list(v.shape)}")
            a = a.copy()
            a.setflags(write=v.flags.writeable)
            values[name] = a
        else:
            if a.shape != ():
                raise TypeError(f"{key}: logged an array, this model a number")
            values[name] = type(v)(a.item())
    return tup._replace(**values)


def rebuilt_parts(loop, logged: dict[str, np.ndarray], parts=None) -> list[str]:
    """The optional parts of ``parts`` (default all) that run in ``loop`` but the log lacks (an
    amplitude-kind log written before its tables were stored): ``apply`` keeps them as rebuilt."""
    return [p for p in OPTIONAL if (parts is None or p in parts) and runs(loop, p)
            and not any(k.startswith(f"params.{p}.") for k in logged)]


def apply(loop, state, logged: dict[str, np.ndarray], parts=None):
    """(loop, state) with the logged parameters of ``parts`` (default: every part of ``PARTS``)
    and the logged initial-state arrays put in; ValueError naming the first field that does not
    fit this version's model (the kernels changed since the log was written). An optional part
    that does not run in ``loop``, or that the log lacks (``rebuilt_parts``), is left as built."""
    skip = set(rebuilt_parts(loop, logged, parts)) | {p for p in OPTIONAL if not runs(loop, p)}
    parts = [p for p in PARTS if (parts is None or p[0] in parts) and p[0] not in skip]
    slots = [slot for part, _ in parts for slot in STATE[part]]
    try:
        new = {}
        for part, path in parts:
            new[path] = _rebuilt(_get(loop, path), f"params.{part}", logged)
        for slot in slots:
            cur, a = getattr(state, slot), logged[f"state.{slot}"]
            if a.shape != cur.shape or a.dtype != cur.dtype:
                raise TypeError(f"state.{slot}: logged {a.dtype}{list(a.shape)}, this model {cur.dtype}{list(cur.shape)}")
    except KeyError as exc:
        raise ValueError(f"the logged design lacks {exc.args[0]}") from None
    except TypeError as exc:
        raise ValueError(f"the logged design does not fit this model ({exc})") from None
    plant_params = new.pop("plant.params", None)
    tracking_params = new.pop("design.params", None)
    fields = dict(new)
    if plant_params is not None:
        fields["plant"] = dataclasses.replace(loop.plant, params=plant_params)
    if tracking_params is not None:
        fields["design"] = dataclasses.replace(loop.design, params=tracking_params)
    loop = dataclasses.replace(loop, **fields)
    state = state.copy()
    for slot in slots:
        getattr(state, slot)[...] = logged[f"state.{slot}"]
    return loop, state


def compare(rebuilt: dict[str, np.ndarray], logged: dict[str, np.ndarray], parts=None) -> dict:
    """How this machine's build differs from the logged one, over the keys of ``parts`` (default
    all) and the state: {"identical": bool, "max_rel_diff": float, "worst": key or None,
    "differing": number of arrays not bit-identical}. max_rel_diff = max |a - b| / max(|b|) per array."""
    chosen = [p for p, _ in PARTS if parts is None or p in parts]
    params = tuple(f"params.{p}." for p in chosen)
    slots = {f"state.{s}" for p in chosen for s in STATE[p]}
    worst, rel, differing = None, 0.0, 0
    for key, b in logged.items():
        if not (key.startswith(params) or key in slots) or key not in rebuilt:
            continue
        a = rebuilt[key]
        if a.shape != b.shape or a.dtype != b.dtype:
            differing += 1
            worst, rel = key, float("inf")
            continue
        if a.tobytes() == b.tobytes():
            continue
        differing += 1
        fa, fb = a.astype(float), b.astype(float)
        scale = float(np.max(np.abs(fb))) if fb.size else 0.0
        r = float(np.max(np.abs(fa - fb))) / scale if scale > 0 else float("inf")
        if r >= rel:
            worst, rel = key, r
    return {"identical": differing == 0, "max_rel_diff": rel, "worst": worst, "differing": differing}


def environment_changes(meta: dict[str, str]) -> list[str]:
    """What differs between the set-up that wrote a log (its "versions", "kernel_version", "kernels",
    "codegen" and "blas" metadata) and this one: e.g. ["numba 0.68.1 -> 0.69.0",
    "kernel version 1 -> 2 (v2: ...)", "codegen generic -> znver5",
    "BLAS Haswell x 1 -> SkylakeX x 2"]; empty
    when all agree or the log records none. Bit-exactness is promised only without changes
    (docs/determinism.md)."""
    import json

    from frictionrt.rt.common.blas import state as blas_state
    from frictionrt.rt.common.codegen import compiled_target
    from frictionrt.rt.common.jit_cache import source_hash
    from frictionrt.rt.common.kernel_version import KERNEL_VERSION, changes_since, logged_version
    from frictionrt.rt.log.writer import package_versions
    out = []
    try:
        then = json.loads(meta.get("versions", "{}"))
        target = json.loads(meta["codegen"]) if "codegen" in meta else None
        blas = json.loads(meta["blas"]) if "blas" in meta else None
    except ValueError:
        return ["the log's versions, codegen or blas record is unreadable"]
    now = package_versions()
    for name in ("python", "numpy", "numba", "llvmlite", "scipy", "control"):
        if isinstance(then, dict) and name in then and then[name] != now.get(name):
            out.append(f"{name} {then[name]} -> {now.get(name)}")
    changed = changes_since(logged_version(meta)) if ("kernel_version" in meta or "kernels" in meta) else []
    if changed:   # a log frictionrt wrote (a measurement records no kernels)
        out.append(f"kernel version {logged_version(meta)} -> {KERNEL_VERSION} ({'; '.join(changed)})")
    if "kernels" in meta and meta["kernels"] != source_hash():
        out.append(f"kernel sources {meta['kernels']} -> {source_hash()}")
    if isinstance(target, dict):
        cur = compiled_target()
        if (target.get("cpu"), target.get("features")) != (cur["cpu"], cur["features"]):
            out.append(f"codegen {target.get('cpu')} -> {cur['cpu']}")
    if isinstance(blas, list):
        def kernels(libs):
            return ", ".join(sorted({f"{d.get('kernels') or '?'} x {d.get('threads')}" for d in libs
                                     if isinstance(d, dict)}))
        if kernels(blas) != kernels(blas_state()):
            out.append(f"BLAS {kernels(blas)} -> {kernels(blas_state())}")
    return out


def describe(report: dict) -> str:
    """One line for the replay's text output: where its design came from and how this build compares."""
    same = report["rebuilt_identical"]
    line = f"  design: {report['why']}"
    if same is False:
        line += (f"; this machine's build differs (max relative {report['max_rel_diff']:.2g} in {report['worst']}: "
                 "another BLAS, libm or dependency version)")
    elif same:
        line += "; this machine's build is bit-identical"
    if report.get("environment"):
        line += "; set-up changed since the log was written: " + ", ".join(report["environment"])
    return line


def use_logged(path, loop, state, sets=(), parts=None, meta=None) -> tuple:
    """(loop, state, report) for a replay of the log at path (module docstring): the logged design
    of ``parts`` put into the rebuilt loop and state, unless ``sets`` overrides the configuration
    or the log has none or it does not fit. report = {"source": "log" | "rebuilt", "why": str,
    "rebuilt_identical": bool or None, "max_rel_diff": float or None, "worst": key or None,
    "environment": ``environment_changes(meta)``}."""
    from frictionrt.rt.log.mcap_log import read_attachment
    report = {"source": "rebuilt", "why": "", "rebuilt_identical": None, "max_rel_diff": None, "worst": None,
              "environment": environment_changes(meta or {})}
    data = read_attachment(path, DESIGN_ATTACHMENT)
    if data is None:
        report["why"] = "the log carries no design (older log or measurement): the configuration rebuilt here"
        return loop, state, report
    try:
        logged = from_npz(data)
        cmp = compare(design_arrays(loop, state), logged, parts)
        report |= {"rebuilt_identical": cmp["identical"], "max_rel_diff": cmp["max_rel_diff"], "worst": cmp["worst"]}
        if sets:
            report["why"] = "--set changes the model: the configuration rebuilt with it"
            return loop, state, report
        rebuilt = rebuilt_parts(loop, logged, parts)
        loop, state = apply(loop, state, logged, parts)
    except ValueError as exc:
        report["why"] = f"{exc}: the configuration rebuilt here"
        return loop, state, report
    report |= {"source": "log", "why": "the design arrays the run used, from the log"}
    if rebuilt:
        report["why"] += (f", but the log carries no {', '.join(rebuilt)} tables (written before they were stored): "
                          "those rebuilt here from the configuration, bit-exact only on the machine that wrote the log")
    return loop, state, report
