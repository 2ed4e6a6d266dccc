"""The float32 kind of the C export (``frictionrt export-c --precision float32``): the controller in
IEEE binary32 for a core with a single-precision FPU only (a Cortex-M4F), with its own golden
vectors and a stated bound on its difference from the double controller (docs/export-c.md, "The
float32 kind").

Design time, here (numpy, once per export):

``realise(rec)``: the float32 parameters of the double design record
(``frictionrt.rt.export.record.controller_record``). The observer's A_d is block diagonal in the
design's modal coordinates (each mode couples its displacement and its velocity state only);
``mode_blocks`` finds the 2 x 2 blocks from its pattern of non-zeros and refuses any other
structure. Each block is stored in delta form, D = A_d[b, b] - I, formed in double and then
rounded, so that the realised pole 1 + eig(fl32(D)) keeps the double pole's frequency and damping
to float32's relative precision of D's small entries. ``pole_errors`` states, per mode, the
realised pole against the double one (Hz, damping) and what rounding A_d itself to float32 would
give. The tip integrator and RT1 are realised the same way (d0 = F1[0] - 1, am1 = a - 1), and the
prefilter's b1 is chosen so that its DC gain is 1 with the rounded coefficients.

``export_float32`` writes the folder: the float32 templates (rt/export/templates/f32_*), the
generated ctrl_config.h and ctrl_design.h, the double kind's golden inputs, and as golden outputs
the float32 bits of this export built on the host (``frictionrt.rt.export.cbuild.build``: a C
compiler is needed at export time), after checking them against the double controller's outputs on
the same stream within ``BOUND``.
"""
from __future__ import annotations

import json
import math
import shutil
from importlib.metadata import version
from pathlib import Path

import numpy as np

from frictionrt.observer.step import NEWTON_MAX
from frictionrt.rt.common.config import dumps
from frictionrt.rt.export.cbuild import OUTPUTS, build
from frictionrt.rt.export.golden import write_golden
from frictionrt.rt.export.record import controller_record, design_hash

TEMPLATES = Path(__file__).with_name("templates")
TEMPLATE_FILES = ("frictionrt_ctrl.h", "frictionrt_ctrl.c", "ctrl_batch.c", "ctrl_check.c", "Makefile")  # from f32_*
PRECISION = "float32"
FNV_OFFSET, FNV_PRIME = 0xcbf29ce484222325, 0x100000001b3
SV_SLOTS = (("code", 0, 1), ("latched", 1, 1), ("passive", 2, 1), ("clean", 4, 1), ("trip_tick", 3, 1),
            ("err", 5, 1), ("sat", 6, 1), ("err_n", 7, 1), ("sat_n", 8, 1), ("overran", 9, 1), ("ovr_n", 10, 1),
            ("ovr_head", 11, 1), ("dis_n", 12, 1), ("last", 13, 5), ("same", 18, 5), ("good", 23, 5),
            ("ring", 28, 64))   # ctrl_supervisor's members in declaration order: (name, slot in state.sv, count)
SV_INT = {"code", "latched", "passive", "clean", "trip_tick", "err_n", "sat_n", "overran", "ovr_n", "ovr_head", "dis_n",
          "same", "ring"}
SUP_INT = {"enable", "auto", "observe"}
SUP_INT32 = {"stuck_ticks", "dis_ticks", "err_ticks", "sat_ticks", "ovr_count", "ovr_ticks", "clean_ticks"}

# The stated equivalence bound of the float32 kind against the double controller, per output: the
# largest |float32 - double| over a replayed run log or the golden stream, fed the same readings.
# V_cmd's grows with the log's length: in a replay the force tracking's integral sums the small
# setpoint difference with nothing to correct it (on a rig the measured force closes that loop), so
# its bound is BOUND_V_RATE per second of log on top of BOUND["V_cmd"]. The measured maxima, the
# margins and the logs: docs/export-c.md "The float32 kind" (benchmarks/export_float32.py).
BOUND = {"F_set": 0.05, "F_set_filtered": 0.05, "V_cmd": 0.05, "v_rel_hat": 1e-6, "u_rel_hat": 1e-9, "u0": 1e-9}
BOUND_V_RATE = 0.1   # [V/s]
DISCRETE = ("saturated", "fault_code", "fault_latched", "passive")   # compared as the share of ticks that agree


def mode_blocks(A: np.ndarray) -> list[tuple[int, int]]:
    """The (i, j) state pairs of A's 2 x 2 diagonal blocks (i < j), from its pattern of non-zeros;
    ValueError unless A is block diagonal with 2 x 2 blocks under that pairing."""
    n = A.shape[0]
    nz = (A != 0) | (A.T != 0)
    np.fill_diagonal(nz, False)
    blocks, seen = [], set()
    for i in range(n):
        if i in seen:
            continue
        partners = np.flatnonzero(nz[i]).tolist()
        if len(partners) != 1 or np.flatnonzero(nz[partners[0]]).tolist() != [i]:
            raise ValueError("export-c --precision float32: the observer's model is not block diagonal by mode "
                             f"(state {i} couples to {partners}); only modal coordinates are realised in float32")
        blocks.append((i, partners[0]))
        seen |= {i, partners[0]}
    return blocks


def _f32(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float64).astype(np.float32)


def realise(rec: dict[str, np.ndarray]) -> dict:
    """The float32 parameters and state at rest of the double design record ``rec`` (module
    docstring): a dict of part -> {field: float32 / integer array}."""
    if "amplitude.grid" in rec:
        raise ValueError("export-c --precision float32: only the observer build (--estimator observer), not "
                         "'amplitude'; export amplitude without --precision (the double kind)")
    if not bool(rec["export.observe"]):
        raise ValueError("export-c --precision float32: only the observer build (--estimator observer); the oracle "
                         "is a test build of the double kind")
    A = rec["observer.A_d"]
    blocks = mode_blocks(A)
    D = np.array([[A[i, i] - 1.0, A[i, j], A[j, i], A[j, j] - 1.0] for i, j in blocks])
    obs = {"blk": np.array(blocks, dtype=np.int16), "D": _f32(D)}
    for f in ("B_dT", "M", "L", "C_meas", "C_u", "C_v", "CvA", "beta", "D_u", "mu", "alpha"):
        obs[f] = _f32(rec[f"observer.{f}"])
    F1 = rec["tip.F1"]
    tip = {"d0": _f32(F1[0] - 1.0), "f1": _f32(F1[1]), "f2": _f32(F1[2])}
    law = {"law": int(rec["law.law"])}
    for f in ("F_min", "F_max", "F_passive", "K_f", "eps", "rt1.b"):
        law[f] = _f32(rec[f"law.{f}"])
    law["rt1.am1"] = _f32(rec["law.rt1.a"] - 1.0)          # RT1 in delta form
    law["hold_voltage"] = int(rec["law.hold_voltage"])
    pre = {f: _f32(rec[f"prefilter.{f}"]) for f in ("b0", "b1", "b2", "a1", "a2")}
    # DC gain 1 with the rounded coefficients: b1 = 1 + a1 + a2 - b0 - b2 (in double, then rounded)
    pre["b1"] = _f32(1.0 + float(pre["a1"]) + float(pre["a2"]) - float(pre["b0"]) - float(pre["b2"]))
    trk = {f: _f32(rec[f"tracking.{f}"]) for f in ("Kp", "Ki_dt", "d_pole", "d_gain", "F0", "inv_c_v", "V_min", "V_max")}
    sup = {}
    for f in ("enable", "auto", "observe", "acc_lo", "acc_hi", "force_hi", "stuck_ticks", "dis_N", "dis_ticks",
              "innovation", "state", "err_N", "err_ticks", "sat_N", "sat_ticks", "ovr_count", "ovr_ticks", "clean_ticks",
              "F_min", "V_passive"):
        v = rec[f"supervisor.{f}"]
        if f in SUP_INT:
            sup[f] = int(v)
        elif f in SUP_INT32:
            if not 0 <= int(v) < 2**31:
                raise ValueError(f"export-c --precision float32: supervisor.{f} = {int(v)} does not fit an int32")
            sup[f] = int(v)
        else:
            sup[f] = _f32(v)
    sv = rec["state.sv"]
    state = {"xs": _f32(rec["state.xs"]), "xe": _f32(rec["state.xe"]), "xl": _f32(rec["state.xl"]),
             "xq": _f32(rec["state.xq"]), "xf": _f32(rec["state.xf"]),
             "sv": {nm: (sv[a:a + n].astype(np.int64) if nm in SV_INT else _f32(sv[a:a + n])) for nm, a, n in SV_SLOTS}}
    return {"observer": obs, "tip": tip, "law": law, "prefilter": pre, "tracking": trk, "supervisor": sup,
            "state": state, "force_col": int(rec["export.force_col"]), "n_obs": A.shape[0], "n_blk": len(blocks)}


def _pole(lam: complex, dt: float) -> tuple[float, float]:
    s = np.log(complex(lam)) / dt
    return abs(s) / (2 * math.pi), -s.real / abs(s)


def pole_errors(rec: dict[str, np.ndarray], dt: float) -> list[dict]:
    """Per mode (block) of the observer: the double pole's frequency [Hz] and damping ratio, the
    float32 delta-form pole's (1 + eig of D rounded to float32) and the pole of A_d's block rounded
    to float32 directly, each eigenvalue computed in double from the rounded entries."""
    A = rec["observer.A_d"]
    rows = []
    for i, j in mode_blocks(A):
        Ab = A[np.ix_([i, j], [i, j])]
        Db = Ab - np.eye(2)
        lam = max(np.linalg.eigvals(Ab), key=lambda z: z.imag)
        mu = max(np.linalg.eigvals(Db.astype(np.float32).astype(np.float64)), key=lambda z: z.imag)
        direct = max(np.linalg.eigvals(Ab.astype(np.float32).astype(np.float64)), key=lambda z: z.imag)
        f, z = _pole(lam, dt)
        f1, z1 = _pole(1.0 + mu, dt)
        f2, z2 = _pole(direct, dt)
        rows.append({"states": [i, j], "f_hz": f, "zeta": z, "ulps32_from_1": (1 - abs(lam)) / 2.0**-24,
                     "delta_f_hz": f1 - f, "delta_zeta": z1 - z, "direct_f_hz": f2 - f, "direct_zeta": z2 - z})
    return rows


def _lit(x) -> str:
    """A C99 float literal of exactly the float32 value x (hexadecimal), or an integer."""
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    x = float(np.float32(x))
    if math.isnan(x):
        raise ValueError("a design parameter is NaN: nothing to export")
    if math.isinf(x):
        return "HUGE_VALF" if x > 0 else "-HUGE_VALF"
    return x.hex() + "f"


def _init(a, indent="    ") -> str:
    """The brace initializer of a scalar or an array (nested for 2-D) of float32 or integers."""
    a = np.asarray(a)
    if a.ndim == 0:
        return _lit(int(a) if a.dtype.kind in "iub" else np.float32(a))
    if a.ndim == 1:
        return "{" + ", ".join(_init(v) for v in a) + "}"
    inner = indent + "    "
    return "{\n" + ",\n".join(inner + _init(r, inner) for r in a) + "\n" + indent + "}"


STRUCTS = (("P_TIP", "tip_params", "tip", ("d0", "f1", "f2")),
           ("P_OBSERVER", "observer_params", "observer",
            ("blk", "D", "B_dT", "M", "L", "C_meas", "C_u", "C_v", "CvA", "beta", "D_u", "mu", "alpha")),
           ("P_LAW", "law_params", "law", ("law", "F_min", "F_max", "F_passive", "K_f", "eps", "rt1.am1", "rt1.b",
                                           "hold_voltage")),
           ("P_PREFILTER", "biquad_params", "prefilter", ("b0", "b1", "b2", "a1", "a2")),
           ("P_TRACKING", "tracking_params", "tracking", ("Kp", "Ki_dt", "d_pole", "d_gain", "F0", "inv_c_v", "V_min",
                                                          "V_max")),
           ("P_SUPERVISOR", "supervisor_params", "supervisor",
            ("enable", "auto", "observe", "acc_lo", "acc_hi", "force_hi", "stuck_ticks", "dis_N", "dis_ticks",
             "innovation", "state", "err_N", "err_ticks", "sat_N", "sat_ticks", "ovr_count", "ovr_ticks",
             "clean_ticks", "F_min", "V_passive")))
C_NAMES = {"auto": "auto_recover"}


def _kind(part: str, field: str, v) -> str:
    """The checksum's element type of a member (frictionrt_ctrl.c sum_<kind>)."""
    if part == "observer" and field == "blk":
        return "int16"
    if part == "supervisor" and field in SUP_INT32:
        return "int32"
    if isinstance(v, int):
        return "int"
    return "float"


def checksum_items(p: dict) -> list[tuple[str, str, np.ndarray]]:
    """(kind, C address, values) of every parameter, in the checksum's order (STRUCTS' order)."""
    items = []
    for name, _, part, fields in STRUCTS:
        for f in fields:
            head, _, sub = f.partition(".")
            v = p[part][f]
            a = np.asarray(v)
            member = f"{head}.{sub}" if sub else C_NAMES.get(f, f)
            items.append((_kind(part, f, v), f"&{name}.{member}" + "[0]" * a.ndim, a))
    return items


def param_checksum(p: dict) -> int:
    """FNV-1a 64 over every parameter as the 4 little-endian bytes of a float32 (integers
    converted): frictionrt_ctrl.c (float32 kind) ``ctrl_param_checksum``."""
    h = FNV_OFFSET
    for _, _, a in checksum_items(p):
        for byte in np.asarray(a).astype("<f4").ravel().tobytes():
            h = ((h ^ byte) * FNV_PRIME) & 0xFFFFFFFFFFFFFFFF
    return h


def reciprocal_sum() -> np.float32:
    """5/3 + 1/3 + 7/3 in float32, left to right: the self-test's expected value."""
    t = np.float32(3)
    return np.float32(np.float32(np.float32(5) / t) + np.float32(np.float32(1) / t)) + np.float32(np.float32(7) / t)


def design_header(p: dict, digest: str) -> str:
    out = [f"/* ctrl_design.h: generated by frictionrt export-c --precision float32; the float32 realisation of\n"
           f" * design {digest}. Hexadecimal floating literals are the exact float32 values. Do not edit. */\n"]
    for name, ctype, part, fields in STRUCTS:
        lines, nested = [], {}
        for f in fields:
            head, _, sub = f.partition(".")
            if sub:
                nested.setdefault(head, []).append(sub)
                continue
            lines.append(f"    .{C_NAMES.get(f, f)} = {_init(p[part][f])},")
        for head, subs in nested.items():
            lines.append(f"    .{head} = {{" + ", ".join(f".{s} = {_init(p[part][f'{head}.{s}'])}" for s in subs) + "},")
        out.append(f"static const {ctype} {name} = {{\n" + "\n".join(lines) + "\n};\n")
    out.append(f"enum {{ P_FORCE_COL = {p['force_col']} }};\n")
    st = p["state"]
    sv = ",\n".join(f"        .{nm} = {_init(st['sv'][nm][0] if n == 1 else st['sv'][nm], '        ')}"
                    for nm, _, n in SV_SLOTS)
    body = ",\n".join(f"    .{s} = {_init(st[s])}" for s in ("xs", "xe", "xl", "xq", "xf"))
    out.append(f"static const ctrl_state CTRL_INITIAL = {{\n{body},\n    .sv = {{\n{sv}\n    }}\n}};\n")
    rows = [f"    X({k}, {a.size}, {addr})" for k, addr, a in checksum_items(p)]
    out.append("#define CTRL_PARAM_LIST(X) \\\n" + " \\\n".join(rows) + "\n")
    return "\n".join(out)


def config_header(p: dict, digest: str, law: str, rate_hz: float) -> str:
    return (f"/* ctrl_config.h: generated by frictionrt export-c --precision float32. Do not edit: export again. */\n"
            f"#ifndef CTRL_CONFIG_H\n#define CTRL_CONFIG_H\n\n"
            f"#define CTRL_PRECISION_FLOAT32 1\n"
            f"#define CTRL_OBSERVER 1\n"
            f"#define CTRL_N_OBS {p['n_obs']}        /* the observer's states */\n"
            f"#define CTRL_N_BLK {p['n_blk']}         /* its modes (2 x 2 blocks) */\n"
            f"#define CTRL_NEWTON_MAX {NEWTON_MAX}  /* the observer's Newton bound: the tick's worst case */\n"
            f"#define CTRL_RATE_HZ {rate_hz!r}\n"
            f"#define CTRL_LAW \"{law}\"\n"
            f"#define CTRL_DESIGN_HASH \"{digest}\"   /* the double design it realises */\n"
            f"#define CTRL_RECIPROCAL_SUM {_lit(reciprocal_sum())}\n"
            f"#define CTRL_PARAM_CHECKSUM 0x{param_checksum(p):016x}ULL\n\n#endif\n")


def bounds(seconds: float) -> dict[str, float]:
    """``BOUND`` for a stream of ``seconds`` [s]: V_cmd's with ``BOUND_V_RATE`` per second."""
    return BOUND | {"V_cmd": BOUND["V_cmd"] + BOUND_V_RATE * seconds}


def differences(out32: np.ndarray, ref: np.ndarray, seconds: float) -> dict:
    """Per output of ``BOUND``: max abs and rms of float32 - double over a stream of ``seconds``
    [s], and its bound (``bounds``); per output of ``DISCRETE``: the ticks that differ (reported,
    not bounded: a flag flips where the double value lies within rounding of a threshold);
    ``within_bound``."""
    res, bound = {}, bounds(seconds)
    for c in BOUND:
        j = OUTPUTS.index(c)
        d = out32[:, j] - ref[:, j]
        res[c] = {"max_abs": float(np.max(np.abs(d))), "rms": float(np.sqrt(np.mean(d * d))), "bound": bound[c]}
    for c in DISCRETE:
        j = OUTPUTS.index(c)
        res[c] = {"ticks_differ": int(np.sum(out32[:, j] != ref[:, j]))}
    ok = all(res[c]["max_abs"] <= bound[c] for c in BOUND) and all(np.isfinite(out32[:, OUTPUTS.index(c)]).all()
                                                                      for c in BOUND)
    return {"by_signal": res, "within_bound": bool(ok)}


def _bits(path: Path, dtype: str, width: int) -> np.ndarray:
    rows = [ln.split() for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    return np.array([[int(v, 16) for v in r[:width]] for r in rows], dtype=dtype)


def export_float32(loop, state, out: Path, source: str, cc: str | None = None) -> dict:
    """Write the float32 export of ``loop`` from ``state`` into ``out`` (module docstring); returns
    the manifest. ValueError in one line for a design it cannot realise, a missing compiler, or
    golden outputs outside ``BOUND`` of the double controller's."""
    from frictionrt.rt.export.generate import FORMAT, MANIFEST
    rec = controller_record(loop, state)
    digest = design_hash(rec)
    p = realise(rec)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for name in TEMPLATE_FILES:
        shutil.copyfile(TEMPLATES / f"f32_{name}", out / name)
    (out / "ctrl_config.h").write_text(config_header(p, digest, loop.law, loop.cfg.rt.rate_hz))
    (out / "ctrl_design.h").write_text(design_header(p, digest))
    (out / "config.toml").write_text(dumps(loop.cfg))
    golden = write_golden(out, loop, state, digest)           # the double kind's stream and outputs
    gin = _bits(out / "golden_in.txt", "<u8", 6)
    ref = _bits(out / "golden_out.txt", "<u8", 13).view("<f8")
    sens = np.ascontiguousarray(gin[:, 1:5]).view("<f8")
    ctrl = build(out, cc, "-O2")
    k = gin[:, 0].astype(np.int64)
    out32 = ctrl.run(k, sens, np.zeros((len(k), 2)), gin[:, 5].astype(np.float64), np.zeros((0, 5)))
    diff = differences(out32, ref, len(k) * loop.cfg.dt_s)
    if not diff["within_bound"]:
        worst = max(BOUND, key=lambda c: diff["by_signal"][c]["max_abs"] / diff["by_signal"][c]["bound"])
        raise ValueError(f"export-c --precision float32: on the golden stream {worst} differs from the double "
                         f"controller by {diff['by_signal'][worst]['max_abs']:.3g} (bound "
                         f"{diff['by_signal'][worst]['bound']:g}): this design "
                         "is not realised within the float32 kind's bound")
    bits = out32.astype(np.float32).view("<u4")
    head = (f"# frictionrt golden {digest}\n# {' '.join(OUTPUTS)} (the IEEE 754 binary32 bits of the float32 "
            f"kind's outputs, this export built with {' '.join(ctrl.command[:2])})\n")
    (out / "golden_out.txt").write_text(head + "\n".join(" ".join(f"{v:08x}" for v in row) for row in bits) + "\n")
    manifest = {"format": FORMAT, "precision": PRECISION, "design_hash": digest,
                "param_checksum": f"{param_checksum(p):016x}", "law": loop.law, "estimator": loop.estimator,
                "force_sensor": loop.force_sensor, "rate_hz": loop.cfg.rt.rate_hz, "source": source,
                "frictionrt": version("frictionrt"), "golden": golden, "bound": BOUND, "bound_V_cmd_per_s": BOUND_V_RATE,
                "golden_vs_double": diff, "poles": pole_errors(rec, loop.cfg.dt_s),
                "files": [*TEMPLATE_FILES, "ctrl_config.h", "ctrl_design.h", "config.toml", "golden_in.txt",
                          "golden_out.txt"]}
    (out / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
    return manifest
