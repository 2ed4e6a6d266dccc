"""Build an export folder's C controller into a shared library and call it through ctypes.

``build(folder, cc, opt, extra)`` compiles frictionrt_ctrl.c and ctrl_batch.c with the
Makefile's flags (``-std=c99 OPT -ffp-contract=off -Wall -Wextra -pedantic``) into a temporary
folder (an export folder may be read-only) and loads the library (``load``: by its path); ``Controller.run`` runs a
whole sensor stream in one foreign call (ctrl_batch.c ``ctrl_run``). No dependency beyond the
standard library's ctypes and a C compiler.
"""
from __future__ import annotations

import ctypes
import os
import shlex
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

BASE_FLAGS = ("-std=c99", "-ffp-contract=off", "-Wall", "-Wextra", "-pedantic")
N_OUTPUTS = 13
OUTPUTS = ("v_tip_meas", "u_rel_hat", "v_rel_hat", "innovation", "f_r_hat", "F_set", "u0", "F_set_filtered",
           "V_cmd", "saturated", "fault_code", "fault_latched", "passive")   # ctrl_outputs order
_dp = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_ip = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")


def compiler(cc: str | None = None) -> str:
    """The C compiler to use: ``cc``, else $CC, else ``cc``; ValueError in one line if it is not
    installed."""
    name = cc or os.environ.get("CC") or "cc"
    first = shlex.split(name)[0] if name.strip() else name
    if not first or shutil.which(first) is None:
        raise ValueError(f"no C compiler {name!r} found (install gcc or clang, or name one with --cc / $CC)")
    return name


@dataclass
class Controller:
    """A loaded build of an export: its library, the flags it was built with, its design hash."""
    lib: ctypes.CDLL
    path: Path
    command: list[str]
    design_hash: str

    def run(self, k: np.ndarray, sens: np.ndarray, uv: np.ndarray, overran: np.ndarray,
            faults: np.ndarray, restarts=None) -> np.ndarray:
        """Outputs (n, 13) in ``OUTPUTS`` order of ticks k from rest: sens (n, 4) a_tip_meas,
        a_frf_meas, F_strain, F_cell; uv (n, 2) for the oracle's test build; overran (n,);
        faults (m, 5) the schedule; restarts: (positions (r,), ctrl_state images (r, state
        doubles)): before tick positions[j] the state is set to image j (ctrl_batch.c
        ``ctrl_run_restarts``)."""
        n = len(k)
        out = np.full((n, N_OUTPUTS), np.nan)
        faults = np.ascontiguousarray(faults, dtype=np.float64).reshape(-1, 5)
        if restarts is not None and len(restarts[0]):
            try:
                f = self.lib.ctrl_run_restarts
            except AttributeError:
                raise ValueError(f"{self.path}: no ctrl_run_restarts (an export of an older frictionrt): export it "
                                 "again to replay across gaps") from None
            f.restype = ctypes.c_int64
            f.argtypes = [ctypes.c_int64, _ip, _dp, _dp, _dp, ctypes.c_void_p, ctypes.c_int, _dp, ctypes.c_int64, _ip, _dp]
            at, states = restarts
            f(n, np.ascontiguousarray(k, dtype=np.int64), np.ascontiguousarray(sens, dtype=np.float64),
              np.ascontiguousarray(uv, dtype=np.float64), np.ascontiguousarray(overran, dtype=np.float64),
              faults.ctypes.data if len(faults) else None, len(faults), out, len(at),
              np.ascontiguousarray(at, dtype=np.int64), np.ascontiguousarray(states, dtype=np.float64))
            return out
        f = self.lib.ctrl_run
        f.restype = ctypes.c_int64
        f.argtypes = [ctypes.c_int64, _ip, _dp, _dp, _dp, ctypes.c_void_p, ctypes.c_int, _dp]
        f(n, np.ascontiguousarray(k, dtype=np.int64), np.ascontiguousarray(sens, dtype=np.float64),
          np.ascontiguousarray(uv, dtype=np.float64), np.ascontiguousarray(overran, dtype=np.float64),
          faults.ctypes.data if len(faults) else None, len(faults), out)
        return out


    def run_timed(self, k: np.ndarray, sens: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(outputs, ns): as ``run`` without overruns or faults, each tick's ctrl_step timed [ns]
        (ctrl_batch.c ``ctrl_run_timed``)."""
        n = len(k)
        out = np.full((n, N_OUTPUTS), np.nan)
        ns = np.zeros(n, dtype=np.int64)
        try:
            f = self.lib.ctrl_run_timed
        except AttributeError:
            raise ValueError(f"{self.path}: no ctrl_run_timed (an export of an older frictionrt): export it again") from None
        f.restype = ctypes.c_int64
        f.argtypes = [ctypes.c_int64, _ip, _dp, _dp, _dp, ctypes.c_void_p, ctypes.c_int, _dp, _ip]
        f(n, np.ascontiguousarray(k, dtype=np.int64), np.ascontiguousarray(sens, dtype=np.float64),
          np.ascontiguousarray(uv, dtype=np.float64), np.zeros(n), None, 0, out, ns)
        return out, ns

    def state_offsets(self) -> list[slice]:
        """Where ctrl_state's members lie, in doubles (ctrl_batch.c ``ctrl_state_offsets``: xs,
        the estimator's state, xl, xq, xf, sv), as slices; ValueError for an older export."""
        try:
            f = self.lib.ctrl_state_offsets
        except AttributeError:
            raise ValueError(f"{self.path}: no ctrl_state_offsets (an export of an older frictionrt): export it "
                             "again") from None
        f.restype = None
        f.argtypes = [ctypes.c_void_p]
        off = np.zeros(7, dtype=np.int64)
        f(off.ctypes.data)
        return [slice(int(a), int(b)) for a, b in zip(off[:-1], off[1:])]

    def state_bytes(self) -> int:
        """sizeof(ctrl_state) of this build."""
        self.lib.ctrl_state_size.restype = ctypes.c_int64
        return int(self.lib.ctrl_state_size())


def build(folder, cc: str | None = None, opt: str = "-O2", extra=(), workdir=None) -> Controller:
    """Compile the export in ``folder`` (``read_manifest`` checked it) and load it. ``cc`` the
    compiler (``compiler``), ``opt`` the optimisation flag, ``extra`` further flags (e.g.
    -Werror, -fsanitize=...). ValueError in one line for a missing compiler or a failed build
    (its first error line)."""
    folder = Path(folder).resolve()
    cmd_cc = shlex.split(compiler(cc))
    work = Path(workdir) if workdir is not None else Path(tempfile.mkdtemp(prefix="frictionrt-c-"))
    lib = work / "libfrictionrt_ctrl.so"
    cmd = [*cmd_cc, *BASE_FLAGS[:1], opt, *BASE_FLAGS[1:], *extra, "-fPIC", "-shared", "-I", str(folder),
           "-o", str(lib), str(folder / "frictionrt_ctrl.c"), str(folder / "ctrl_batch.c")]
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            first = next((ln for ln in r.stderr.splitlines() if "error" in ln), r.stderr.strip()[:200])
            raise ValueError(f"--c {folder}: the C build failed ({' '.join(cmd_cc)} {opt}): {first}")
        return load(lib, cmd)
    finally:
        if workdir is None:   # a loaded library stays mapped: the temporary folder can go
            shutil.rmtree(work, ignore_errors=True)


def load(lib, command=()) -> Controller:
    """A library ``build`` wrote, loaded (by its path: a worker process loads the parent's build so;
    ``command``: how it was built, for the record)."""
    dll = ctypes.CDLL(str(lib))
    dll.ctrl_design_hash.restype = ctypes.c_char_p
    guard = getattr(dll, "ctrl_selftest", None)
    if guard is not None:   # exports before the guards have none
        guard.restype = ctypes.c_int
        rc = guard()
        if rc != 0:
            dll.ctrl_error_text.restype = ctypes.c_char_p
            dll.ctrl_error_text.argtypes = [ctypes.c_int]
            raise ValueError(f"{lib}: the C build fails ctrl_init's guard {rc}: "
                             f"{dll.ctrl_error_text(rc).decode()} (built with: {' '.join(command)})")
    return Controller(dll, Path(lib), list(command), dll.ctrl_design_hash().decode())
