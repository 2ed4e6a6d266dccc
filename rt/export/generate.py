"""``frictionrt export-c``: write the C controller of a design into a folder.

The C sources are templates in rt/export/templates (readable, commented C99: frictionrt_ctrl.h,
frictionrt_ctrl.c, the batch entry ctrl_batch.c, the harness ctrl_harness.c, the Makefile),
copied as they are. Only the numbers are generated, from the controller's design record
(``frictionrt.rt.export.record``):

    ctrl_config.h       the estimator (CTRL_OBSERVER, CTRL_AMPLITUDE), the observer's sizes, the
                        Newton bound, the design hash, the parameters' checksum
                        CTRL_PARAM_CHECKSUM (``param_checksum``)
    ctrl_design.h       every parameter as a C99 designated initializer of the template's
                        structs, in hexadecimal floating literals (the exact bits), the
                        state at rest CTRL_INITIAL, and CTRL_PARAMS: where each value of the
                        design record lies, in the record's key order (the checksum's order)
    golden_in.txt, golden_out.txt   the golden vectors (``frictionrt.rt.export.golden``): what
                        ``make check`` (ctrl_check.c) runs the compiled controller on
    frictionrt_export.json   what the folder holds: the hash, law, estimator, where the design
                        came from; ``frictionrt replay --c`` reads it
    config.toml         the resolved configuration (for the record; the C does not read it)
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
from frictionrt.rt.export.golden import write_golden
from frictionrt.rt.export.record import controller_record, design_hash

TEMPLATES = Path(__file__).with_name("templates")
TEMPLATE_FILES = ("frictionrt_ctrl.h", "frictionrt_ctrl.c", "ctrl_batch.c", "ctrl_harness.c", "ctrl_check.c", "ctrl_rt_main.c",
                  "Makefile")
GOLDEN_FILES = ("golden_in.txt", "golden_out.txt")
MANIFEST = "frictionrt_export.json"
FORMAT = "frictionrt-export-c/1"
# the fields of the template's parameter structs (frictionrt_ctrl.c), per part of the record
C_FIELDS = {
    "oracle": ("b0", "b1", "b2", "a1", "a2"),
    "prefilter": ("b0", "b1", "b2", "a1", "a2"),
    "observer": ("A_d", "B_dT", "M", "L", "C_meas", "C_u", "C_v", "CvA", "beta", "D_u", "mu", "alpha"),
    "law": ("law", "F_min", "F_max", "F_passive", "K_f", "eps", "rt1.a", "rt1.b", "hold_voltage"),
    "tracking": ("Kp", "Ki_dt", "d_pole", "d_gain", "F0", "inv_c_v", "V_min", "V_max"),
    "supervisor": ("enable", "auto", "observe", "acc_lo", "acc_hi", "force_hi", "stuck_ticks", "dis_N", "dis_ticks",
                   "innovation", "state", "err_N", "err_ticks", "sat_N", "sat_ticks", "ovr_count", "ovr_ticks",
                   "clean_ticks", "F_min", "V_passive"),
    "tip": ("F1",),
    "amplitude": ("grid", "blocks", "scale", "inv_omega", "k_j"),
}
C_NAMES = {"auto": "auto_recover"}   # a C keyword
C_INT = {"law.law", "law.hold_voltage", "supervisor.enable", "supervisor.auto", "supervisor.observe"}  # C int; other integers int64_t
STRUCTS = {"tip": "P_TIP", "oracle": "P_ORACLE", "observer": "P_OBSERVER", "law": "P_LAW", "prefilter": "P_PREFILTER",
           "tracking": "P_TRACKING", "supervisor": "P_SUPERVISOR", "state": "CTRL_INITIAL", "amplitude": "P_AMPLITUDE"}
FNV_OFFSET, FNV_PRIME = 0xcbf29ce484222325, 0x100000001b3
C_TYPES = {"oracle": "biquad_params", "prefilter": "biquad_params", "observer": "observer_params",
           "law": "law_params", "tracking": "tracking_params", "supervisor": "supervisor_params", "tip": "tip_params",
           "amplitude": "amplitude_params"}
ESTIMATORS = ("observer", "amplitude", "oracle")   # the estimators the templates hold


def literal(x) -> str:
    """A C99 literal of exactly the value x: hexadecimal floating for floats (HUGE_VAL for
    infinities), decimal for integers, 0/1 for booleans. ValueError for NaN."""
    if isinstance(x, (bool, np.bool_)):
        return "1" if x else "0"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    x = float(x)
    if math.isnan(x):
        raise ValueError("a design parameter is NaN: nothing to export")
    if math.isinf(x):
        return "HUGE_VAL" if x > 0 else "-HUGE_VAL"
    return x.hex()


def initializer(a: np.ndarray, indent: str = "") -> str:
    """The brace initializer of an array (nested for 2-D), one row per line."""
    a = np.asarray(a)
    if a.ndim == 0:
        return literal(a.item())
    if a.ndim == 1:
        return "{" + ", ".join(literal(v) for v in a.tolist()) + "}"
    inner = indent + "    "
    return "{\n" + ",\n".join(inner + initializer(row, inner) for row in a) + "\n" + indent + "}"


def _comment(a: np.ndarray) -> str:
    a = np.asarray(a)
    return f" /* {a.item()!r} */" if a.ndim == 0 and a.dtype.kind == "f" else ""


def _struct(name: str, part: str, rec: dict[str, np.ndarray]) -> str:
    keys = sorted(k[len(part) + 1:] for k in rec if k.startswith(part + "."))
    if sorted(C_FIELDS[part]) != keys:
        raise ValueError(f"the C templates do not match the controller's {part} parameters (design {keys}, "
                         f"templates {sorted(C_FIELDS[part])}): the kernels changed; update rt/export/templates")
    lines, nested = [], {}
    for f in C_FIELDS[part]:
        head, _, sub = f.partition(".")
        if sub:
            nested.setdefault(head, []).append(sub)
            continue
        a = rec[f"{part}.{f}"]
        lines.append(f"    .{C_NAMES.get(f, f)} = {initializer(a, '    ')},{_comment(a)}")
    for head, subs in nested.items():
        inner = ", ".join(f".{s} = {literal(rec[f'{part}.{head}.{s}'].item())}" for s in subs)
        lines.append(f"    .{head} = {{{inner}}},")
    return f"static const {C_TYPES[part]} {name} = {{\n" + "\n".join(lines) + "\n};\n"


def checksummed(rec: dict[str, np.ndarray]) -> list[str]:
    """The record's keys the checksum covers, in its order: every parameter and initial state
    (not ``export.*``, the build's kind)."""
    return [k for k in sorted(rec) if not k.startswith("export.")]


def param_checksum(rec: dict[str, np.ndarray]) -> int:
    """FNV-1a 64 over the values of ``checksummed`` keys, each as the 8 little-endian bytes of a
    double (integers and booleans converted exactly): frictionrt_ctrl.c ``ctrl_param_checksum``."""
    h = FNV_OFFSET
    for key in checksummed(rec):
        for byte in np.asarray(rec[key]).astype("<f8").ravel().tobytes():
            h = ((h ^ byte) * FNV_PRIME) & 0xFFFFFFFFFFFFFFFF
    return h


def _param_table(rec: dict[str, np.ndarray]) -> str:
    """CTRL_PARAM_LIST: per checksummed key X(type, count, address), an X-macro (no table of
    pointers in memory: the object keeps no relocated data)."""
    rows = []
    for key in checksummed(rec):
        part, _, field = key.partition(".")
        a = np.asarray(rec[key])
        kind = "double" if a.dtype.kind == "f" else "int" if key in C_INT else "int64"
        member = ".".join(C_NAMES.get(f, f) for f in field.split("."))
        addr = f"&{STRUCTS[part]}.{member}" + ("[0]" * a.ndim)
        rows.append(f"    X({kind}, {a.size}, {addr})   /* {key} */")
    return ("/* where each value of the design record lies, in its key order (ctrl_param_checksum) */\n"
            "#define CTRL_PARAM_LIST(X) \\\n" + " \\\n".join(rows) + "\n")


def design_header(rec: dict[str, np.ndarray], digest: str) -> str:
    """ctrl_design.h: the parameter structs and the state at rest (module docstring)."""
    observe = bool(rec["export.observe"])
    out = [f"/* ctrl_design.h: generated by frictionrt export-c; the numbers of design {digest}.\n"
           " * Included by frictionrt_ctrl.c only; hexadecimal floating literals are the exact bits\n"
           " * (decimal values in the comments). Do not edit: export again. */\n"]
    out.append(_struct("P_TIP", "tip", rec))
    out.append(_struct("P_OBSERVER" if observe else "P_ORACLE", "observer" if observe else "oracle", rec))
    if any(k.startswith("amplitude.") for k in rec):   # the amplitude-following observer's blocks
        out.append(_struct("P_AMPLITUDE", "amplitude", rec))
    for name, part in (("P_LAW", "law"), ("P_PREFILTER", "prefilter"), ("P_TRACKING", "tracking"),
                       ("P_SUPERVISOR", "supervisor")):
        out.append(_struct(name, part, rec))
    out.append(f"/* the reading the force tracking uses: {int(rec['export.force_col'])} = "
               f"{'F_cell' if int(rec['export.force_col']) == 4 else 'F_strain'} */\n"
               f"enum {{ P_FORCE_COL = {int(rec['export.force_col'])} }};\n")
    slots = ["xs", "xe" if observe else "xo", "xl", "xq", "xf", "sv"]
    body = ",\n".join(f"    .{s} = {initializer(rec[f'state.{s}'], '    ')}" for s in slots)
    out.append("/* the state at rest (the run's initial state) */\n"
               f"static const ctrl_state CTRL_INITIAL = {{\n{body}\n}};\n")
    out.append(_param_table(rec))
    return "\n".join(out)


def config_header(rec: dict[str, np.ndarray], digest: str, law: str, rate_hz: float) -> str:
    """ctrl_config.h: sizes, the estimator and the hash (module docstring)."""
    observe = bool(rec["export.observe"])
    n = rec["observer.M"].shape[0] if observe else 0
    n_state = rec["state.xe"].shape[0] if observe else 0
    amplitude = "amplitude.grid" in rec
    grid = (f"#define CTRL_N_GRID {rec['amplitude.grid'].shape[0]}       /* the amplitude grid's points */\n"
            if amplitude else "")
    return (f"/* ctrl_config.h: generated by frictionrt export-c. Do not edit: export again. */\n"
            f"#ifndef CTRL_CONFIG_H\n#define CTRL_CONFIG_H\n\n"
            f"#define CTRL_OBSERVER {int(observe)}      /* 1 an observer, 0 the oracle (a test build: inputs u_rel, v_rel) */\n"
            f"#define CTRL_AMPLITUDE {int(amplitude)}     /* 1 the amplitude-following observer, 0 the paper's */\n"
            f"#define CTRL_N_OBS {n}        /* the observer's model states (2 per mode) */\n"
            f"#define CTRL_N_STATE {n_state}      /* the observer's state (CTRL_N_OBS, + 1: the Jenkins joint's slider) */\n"
            f"{grid}"
            f"#define CTRL_NEWTON_MAX {NEWTON_MAX}  /* the observer's Newton bound: the tick's worst case */\n"
            f"#define CTRL_RATE_HZ {literal(rate_hz)}  /* {rate_hz:g} Hz */\n"
            f"#define CTRL_LAW \"{law}\"\n"
            f"#define CTRL_DESIGN_HASH \"{digest}\"\n"
            f"#define CTRL_PARAM_CHECKSUM 0x{param_checksum(rec):016x}ULL  /* of ctrl_design.h's CTRL_PARAMS */\n\n#endif\n")


def export_c(loop, state, out: Path, source: str) -> dict:
    """Write the export of ``loop`` started from ``state`` into the folder ``out`` (created if
    missing); ``source`` says where the design came from. Returns the manifest. ValueError for an
    estimator the templates do not hold (``ESTIMATORS``), before anything is written."""
    if loop.estimator not in ESTIMATORS:
        raise ValueError(f"estimator {loop.estimator!r}: the C export has templates for {', '.join(ESTIMATORS)} "
                         "only; export with --estimator observer")
    rec = controller_record(loop, state)
    digest = design_hash(rec)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for name in TEMPLATE_FILES:
        shutil.copyfile(TEMPLATES / name, out / name)
    (out / "ctrl_config.h").write_text(config_header(rec, digest, loop.law, loop.cfg.rt.rate_hz))
    (out / "ctrl_design.h").write_text(design_header(rec, digest))
    (out / "config.toml").write_text(dumps(loop.cfg))
    golden = write_golden(out, loop, state, digest)
    manifest = {"format": FORMAT, "design_hash": digest, "param_checksum": f"{param_checksum(rec):016x}",
                "law": loop.law, "estimator": loop.estimator,
                "force_sensor": loop.force_sensor, "rate_hz": loop.cfg.rt.rate_hz, "source": source,
                "frictionrt": version("frictionrt"), "golden": golden,
                "files": [*TEMPLATE_FILES, "ctrl_config.h", "ctrl_design.h", "config.toml", *GOLDEN_FILES]}
    (out / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n")
    return manifest


def read_manifest(folder: Path) -> dict:
    """The manifest of an export folder; ValueError naming the folder if it is not one."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"--c {folder}: {'not a folder' if folder.exists() else 'no such folder'} "
                         "(give the folder frictionrt export-c -o wrote)")
    try:
        m = json.loads((folder / MANIFEST).read_text())
    except (OSError, ValueError):
        m = None
    if not isinstance(m, dict) or m.get("format") != FORMAT or not isinstance(m.get("design_hash"), str):
        raise ValueError(f"--c {folder}: not a frictionrt C export (no valid {MANIFEST}; write one with "
                         "frictionrt export-c -o DIR)")
    missing = [f for f in m.get("files", TEMPLATE_FILES) if not (folder / f).is_file()]
    if missing:
        raise ValueError(f"--c {folder}: the export lacks {', '.join(missing)}; export it again")
    return m


def check_design(manifest: dict, digest: str, loop, option: str, whose: str, hint: str = "") -> None:
    """ValueError in one line, naming both designs (hash, law/estimator), unless the export of
    ``manifest`` is of the design ``digest`` of ``loop``: "OPTION: an export of another design
    (...) than WHOSE (...)HINT". Every user of an export checks it so."""
    if manifest["design_hash"] != digest:
        raise ValueError(f"{option}: an export of another design ({manifest['design_hash'][:19]}..., "
                         f"{manifest['law']}/{manifest['estimator']}) than {whose} ({digest[:19]}..., "
                         f"{loop.law}/{loop.estimator}){hint}")


def require_double(manifest: dict, option: str) -> None:
    """ValueError in one line when ``manifest`` is of a float32 export (``frictionrt.rt.export.float32``):
    software in the loop and the controller benchmark need the double kind's bits and state layout."""
    if manifest.get("precision", "double") != "double":
        raise ValueError(f"{option}: a {manifest['precision']} export runs on its target and in replay --c only "
                         "(its own bound, not the double controller's bits); give a double export (export-c "
                         "without --precision)")
