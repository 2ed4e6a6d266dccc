"""Measured FRF files: frequency responses H_s = response_s / excitation of the
sensors over frequency lines, one file per test (one excitation level, one bolt force F_N1), as a
lab exports them, with a JSON sidecar that says what was measured where. Format:
docs/data-format.md, "FRF files".

The response is the sidecar's ``quantity`` (``QUANTITIES``: accelerance (m/s^2)/N, the default,
mobility (m/s)/N or receptance m/N), the excitation its ``excitation`` (``EXCITATIONS``: the
measured force, the default, or the shaker's drive voltage, then H is per volt). A sensor is any
name that is a ROS 2 field name (rt.log.registry.FIELD_RE, lowercase snake_case), placed by
``sensor_positions_m`` (and, where beams overlap, ``sensor_beams``).

* CSV ``<stem>.csv``: header ``freq_hz[,F_amp_N][,drive_amp_N],<sensor>_re,<sensor>_im[,<sensor>_coh],...``,
  one row per frequency line; written with ``repr`` floats, so a round trip is bit-exact. The optional
  ``<sensor>_coh`` column is the sensor's coherence gamma^2 (0..1) of a random test's H1.
* UFF ``<stem>.uff`` (or .unv): universal file, one data set 58 per sensor (function type 4 =
  frequency response function, complex ordinate, abscissa frequency in Hz, ID line 1 = sensor
  name), plus one real data set 58 of function type 0 (general) per optional amplitude column
  (ID line 1 = F_amp_N or drive_amp_N), and one real data set 58 of function type 6 (coherence) per
  sensor with a coherence (ID line 1 = sensor name). Written by pyuff in ASCII, uneven abscissa: the frequency
  with 6 significant digits (E13.5, relative error <= 5e-6), the ordinate with 12 (E20.11,
  relative error <= 5e-12); binary 58b files go to pyuff's reader too (not tested).
* sidecar ``<stem>.json``: {"format": "frictionrt-frf/1", "kind": "stepsine" | "frf",
  "excitation_x_m", "sensor_positions_m": {sensor: x_m}, "F_N1_N", "amplitude_n", "description"}
  and optionally "quantity", "excitation", "sensor_beams": {sensor: beam}, "drive_amplitude_v" (the drive
  voltage's amplitude [V] of a drive_voltage test at one level), "random" (a random test:
  {"rms", "band_hz": [f_lo, f_hi], "block_s", "averages", "overlap", "window"}, the level ``rms`` the force's [N]
  or, for a drive_voltage test, the drive voltage's [V] rms over the band, amplitude_n and
  drive_amplitude_v then null; ``check_random``) (``OPTIONAL_KEYS``, their defaults those of a file
  without them: accelerance per newton, beams found from x, a sine).
* UFF ordinate data characteristics: numerator 8 / 11 / 12 (displacement, velocity, acceleration)
  for receptance / mobility / accelerance, denominator 13 (excitation force) or 0 (unknown: a
  voltage has no code) for a drive voltage; a reader checks a stated numerator (8, 11, 12) and
  denominator (13) against the sidecar.

Readers raise ValueError naming the file, the problem and the fix. Writers are atomic (a temporary
file in the same folder, then ``os.replace``); the sidecar is in place before its data file
appears, and a failed write leaves neither.

Length: one file format, its CSV and UFF writers and readers around the sidecar checks they all
share (check_meta, check_lines); split, the readers and the checks would import each other.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from frictionrt.rt.log.data_format import ACCELEROMETER_POINTS
from frictionrt.rt.log.registry import FIELD_RE, RESERVED

FORMAT = "frictionrt-frf/1"
KINDS = ("stepsine", "frf")
SENSORS = tuple(ACCELEROMETER_POINTS)          # a_tip_meas, a_frf_meas: the measurement format's accelerometers
QUANTITIES = {"accelerance": (2, "m/s^2", 12), "mobility": (1, "m/s", 11), "receptance": (0, "m", 8)}
"""quantity -> (time derivatives of the displacement k, response unit, UFF 58 ordinate data characteristic):
H_quantity = H_accelerance / (i omega)^(2 - k)."""
EXCITATIONS = {"force": ("N", 13), "drive_voltage": ("V", 0)}
"""excitation -> (unit of the FRF's denominator, UFF 58 ordinate-denominator data characteristic)."""
OPTIONAL_KEYS = {"quantity": "accelerance", "excitation": "force", "sensor_beams": {}, "drive_amplitude_v": None,
                 "random": None, "broadband": False}
"""Sidecar keys a file may omit, with the value a file without them has."""
AMPLITUDES = ("F_amp_N", "drive_amp_N")         # optional per-line columns [N]
UFF_SUFFIXES = (".uff", ".unv")
SUFFIXES = (".csv",) + UFF_SUFFIXES
FUNC_FRF, FUNC_GENERAL, FUNC_COHERENCE = 4, 0, 6  # UFF 58 function types
SPEC_FREQUENCY, SPEC_FORCE = 18, 13              # UFF 58 data characteristics
SIDECAR_KEYS = ("format", "kind", "excitation_x_m", "sensor_positions_m", "F_N1_N", "amplitude_n", "description")
FIX_DOC = 'docs/data-format.md, "FRF files"'


@dataclass(frozen=True)
class FRFTest:
    """One FRF measurement at one excitation level."""
    name: str                       # file stem
    freq_hz: np.ndarray             # (n,) strictly increasing, > 0 [Hz]
    H: dict                         # sensor name -> complex (n,) FRF of the sidecar's quantity and excitation
    F_amp_N: np.ndarray | None      # (n,) measured force amplitude per line [N] (step-sine), or None
    drive_amp: np.ndarray | None    # (n,) shaker drive amplitude per line as an ideal source's force [N], or None
    meta: dict                      # the sidecar
    coherence: dict | None = None   # sensor -> (n,) coherence gamma^2 of a random test's H1 [-], or None

    @property
    def F_N1(self) -> float:
        """Mean bolt force during the test [N] (sidecar F_N1_N)."""
        return float(self.meta["F_N1_N"])

    @property
    def quantity(self) -> str:
        """accelerance, mobility or receptance (sidecar quantity, default accelerance)."""
        return self.meta.get("quantity", OPTIONAL_KEYS["quantity"])

    @property
    def excitation(self) -> str:
        """force or drive_voltage (sidecar excitation, default force)."""
        return self.meta.get("excitation", OPTIONAL_KEYS["excitation"])

    @property
    def unit(self) -> str:
        """The unit of H, e.g. (m/s^2)/N, m/V."""
        return frf_unit(self.quantity, self.excitation)


def frf_unit(quantity: str, excitation: str) -> str:
    """Unit of an FRF of ``quantity`` per ``excitation``: (m/s^2)/N, (m/s)/V, m/N, ..."""
    num, den = QUANTITIES[quantity][1], EXCITATIONS[excitation][0]
    return f"{num}/{den}" if num == "m" else f"({num})/{den}"


def from_accelerance(H_a: np.ndarray, freq_hz: np.ndarray, quantity: str) -> np.ndarray:
    """An accelerance [(m/s^2)/N] on freq_hz [Hz] as ``quantity``: H_a / (i omega)^(2 - k), k the
    quantity's time derivatives of the displacement (QUANTITIES)."""
    k = QUANTITIES[quantity][0]
    return H_a if k == 2 else H_a / (2j * np.pi * np.asarray(freq_hz, float)) ** (2 - k)


def sidecar_path(path: str | os.PathLike) -> Path:
    """The sidecar of a data file: same folder and stem, suffix .json."""
    return Path(path).with_suffix(".json")


# --- checks (problem + fix, without the file name: the callers add it) ---------------------------

def _finite(x, what: str, positive: bool = False, non_negative: str = "") -> float:
    """x as a float; ValueError if not finite, not > 0 (``positive``) or below 0 (``non_negative``:
    what 0 means, for the message)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        raise ValueError(f"{what} is {x!r}, not a finite number; give it in SI units ({FIX_DOC})")
    if positive and x <= 0:
        raise ValueError(f"{what} is {x!r}; it must be > 0")
    if non_negative and x < 0:
        raise ValueError(f"{what} is {x!r}; it must be >= 0 ({non_negative})")
    return float(x)


def check_meta(meta) -> dict:
    """The sidecar ``meta`` checked (module docstring); ValueError with the problem and the fix."""
    if not isinstance(meta, dict):
        raise ValueError(f"the sidecar is a JSON {type(meta).__name__}, not an object with the keys "
                         f"{', '.join(SIDECAR_KEYS)}")
    miss = [k for k in SIDECAR_KEYS if k not in meta]
    if miss:
        raise ValueError(f"sidecar key(s) {', '.join(miss)} missing; add them ({FIX_DOC})")
    if meta["format"] != FORMAT:
        raise ValueError(f"sidecar format is {meta['format']!r}; this reader knows {FORMAT!r}")
    if meta["kind"] not in KINDS:
        raise ValueError(f"sidecar kind is {meta['kind']!r}; give one of {', '.join(KINDS)}")
    _finite(meta["excitation_x_m"], "sidecar excitation_x_m")
    _finite(meta["F_N1_N"], "sidecar F_N1_N", non_negative="0: a structure without an adaptive screw")
    if meta["amplitude_n"] is not None:
        _finite(meta["amplitude_n"], "sidecar amplitude_n", positive=True)
    if not isinstance(meta["description"], str):
        raise ValueError("sidecar description is not a string")
    pos = meta["sensor_positions_m"]
    if not isinstance(pos, dict) or not pos:
        raise ValueError(f"sidecar sensor_positions_m is {pos!r}; give an object {{sensor: x_m}} for the "
                         f"sensors of the file (e.g. {', '.join(SENSORS)})")
    for s, x in pos.items():
        check_sensor_name(s, "sidecar sensor_positions_m names the sensor")
        _finite(x, f"sidecar sensor_positions_m.{s}")
    for key, allowed in (("quantity", QUANTITIES), ("excitation", EXCITATIONS)):
        v = meta.get(key, OPTIONAL_KEYS[key])
        if not isinstance(v, str) or v not in allowed:
            raise ValueError(f"sidecar {key} is {str(v)[:40]!r}; give one of {', '.join(allowed)} (default "
                             f"{OPTIONAL_KEYS[key]}; {FIX_DOC})")
    if meta.get("drive_amplitude_v") is not None:
        if meta.get("excitation", OPTIONAL_KEYS["excitation"]) != "drive_voltage":
            raise ValueError("sidecar drive_amplitude_v is given, but the excitation is a force; give excitation "
                             "drive_voltage or leave drive_amplitude_v out")
        _finite(meta["drive_amplitude_v"], "sidecar drive_amplitude_v", positive=True)
    if meta.get("random") is not None:
        check_random(meta)
    if not isinstance(meta.get("broadband", False), bool):
        raise ValueError(f"sidecar broadband is {str(meta['broadband'])[:40]!r}; give true (a low-level FRF over the "
                         "whole band beside level tests) or false, or leave it out")
    beams = meta.get("sensor_beams", {})
    if not isinstance(beams, dict):
        raise ValueError(f"sidecar sensor_beams is {str(beams)[:40]!r}; give an object {{sensor: beam name}} or "
                         "leave it out")
    for s, b in beams.items():
        if s not in pos:
            raise ValueError(f"sidecar sensor_beams names {str(s)[:40]!r}, which has no sensor_positions_m entry; "
                             "place the sensor there too")
        if not isinstance(b, str) or not b:
            raise ValueError(f"sidecar sensor_beams.{s} is {str(b)[:40]!r}; give the name of a beam of the structure")
    return meta


def check_random(meta: dict) -> None:
    """The sidecar's "random" object (module docstring) checked; ValueError with the problem and the fix."""
    r = meta["random"]
    keys = ("rms", "band_hz", "block_s", "averages", "overlap", "window")
    if not isinstance(r, dict) or any(k not in r for k in keys):
        raise ValueError(f"sidecar random is {str(r)[:60]!r}; give an object with {', '.join(keys)} ({FIX_DOC})")
    for k in ("rms", "block_s", "averages"):
        _finite(r[k], f"sidecar random.{k}", positive=True)
    _finite(r["overlap"], "sidecar random.overlap", non_negative="no overlap")
    b = r["band_hz"]
    if not (isinstance(b, list) and len(b) == 2 and 0 <= _finite(b[0], "sidecar random.band_hz[0]")
            < _finite(b[1], "sidecar random.band_hz[1]")):
        raise ValueError(f"sidecar random.band_hz is {str(b)[:40]!r}; give [f_lo, f_hi] in Hz, 0 <= f_lo < f_hi")
    if meta["amplitude_n"] is not None or meta.get("drive_amplitude_v") is not None:
        raise ValueError("sidecar random is given with amplitude_n or drive_amplitude_v: a random test's level is "
                         "random.rms; set the amplitudes to null")


def check_sensor_name(s, what: str = "sensor") -> str:
    """``s`` if it is a valid sensor name: a ROS 2 field name (rt.log.registry.FIELD_RE: lowercase
    letters, digits and single underscores, starting with a letter) other than stamp, tick;
    ValueError otherwise."""
    if not isinstance(s, str) or not FIELD_RE.match(s) or s in RESERVED:
        raise ValueError(f"{what} {str(s)[:40]!r}, which is not a valid sensor name: name sensors in lowercase "
                         f"snake_case (a ROS 2 field name: letters a-z, digits, single underscores, a letter first, "
                         f"not {' or '.join(RESERVED)}; e.g. v_tip_laser, a_frf_meas)")
    return s


def check_lines(freq_hz: np.ndarray, H: dict, F_amp_N, drive_amp, meta: dict, coherence: dict | None = None) -> None:
    """Frequency lines > 0 and strictly increasing, at least 2; every array (n,) and finite; every
    sensor known and placed in the sidecar; a coherence only of a sensor with an FRF, within 0..1."""
    n = len(freq_hz)
    if n < 2:
        raise ValueError(f"{n} frequency line(s); an FRF needs at least 2")
    if not np.all(np.isfinite(freq_hz)):
        raise ValueError(f"frequency line {int(np.argmin(np.isfinite(freq_hz))) + 1} is not finite (NaN or inf)")
    if freq_hz[0] <= 0:
        raise ValueError(f"the first frequency is {float(freq_hz[0])!r} Hz; frequencies must be > 0 "
                         "(drop the 0 Hz line)")
    bad = np.flatnonzero(np.diff(freq_hz) <= 0)
    if len(bad):
        i = int(bad[0])
        raise ValueError(f"frequency not increasing at line {i + 2}: {float(freq_hz[i + 1])!r} Hz after "
                         f"{float(freq_hz[i])!r} Hz; "
                         "sort the lines and drop repeated frequencies")
    if not H:
        raise ValueError("no sensor; give the FRF of at least one sensor")
    for s, h in H.items():
        check_sensor_name(s)
        if s not in meta["sensor_positions_m"]:
            raise ValueError(f"sensor {s} has no position in the sidecar; add sensor_positions_m.{s}")
        _check_array(h, s, n)
    for name, a in zip(AMPLITUDES, (F_amp_N, drive_amp)):
        if a is not None:
            _check_array(a, name, n)
            if np.any(a <= 0):
                raise ValueError(f"{name} <= 0 at line {int(np.argmax(a <= 0)) + 1}; amplitudes are > 0 [N]")
    for s, g in (coherence or {}).items():
        if s not in H:
            raise ValueError(f"a coherence of {str(s)[:40]!r}, which has no FRF; give its FRF too or drop the "
                             "coherence")
        _check_array(g, f"{s} coherence", n)
        if np.any((g < 0) | (g > 1)):
            raise ValueError(f"{s} coherence outside 0..1 at line {int(np.argmax((g < 0) | (g > 1))) + 1}; "
                             "gamma^2 = |S_fa|^2 / (S_ff S_aa) lies within 0..1")


def _check_array(a: np.ndarray, name: str, n: int) -> None:
    if np.shape(a) != (n,):
        raise ValueError(f"{name} has shape {np.shape(a)}, the frequency lines {n}")
    ok = np.isfinite(a)
    if not np.all(ok):
        raise ValueError(f"{name} is NaN or inf at line {int(np.argmin(ok)) + 1}; drop or re-measure the line")


def check_test(test: FRFTest) -> None:
    """A test as the writers and readers accept it; ValueError otherwise."""
    check_meta(test.meta)
    check_lines(np.asarray(test.freq_hz, float), test.H, test.F_amp_N, test.drive_amp, test.meta, test.coherence)


# --- writers -------------------------------------------------------------------------------------

def _atomic_write(path: Path, write, before_replace=None) -> None:
    """``write(tmp_path)`` on a temporary file beside ``path``, then ``before_replace()`` (if given),
    then os.replace onto ``path``."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.chmod(tmp, 0o644)
        if before_replace is not None:
            before_replace()
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _write_sidecar(path: Path, test: FRFTest) -> None:
    meta = {k: test.meta[k] for k in (*SIDECAR_KEYS, *OPTIONAL_KEYS) if k in test.meta}
    _atomic_write(sidecar_path(path), lambda p: p.write_text(json.dumps(meta, indent=1) + "\n"))


def write_frf_csv(path: str | os.PathLike, test: FRFTest) -> None:
    """``test`` as ``path`` (.csv) and its sidecar; floats as repr (bit-exact round trip)."""
    path = Path(path)
    check_test(test)
    cols, names = [np.asarray(test.freq_hz, float)], ["freq_hz"]
    for name, a in zip(AMPLITUDES, (test.F_amp_N, test.drive_amp)):
        if a is not None:
            cols.append(np.asarray(a, float))
            names.append(name)
    for s, h in test.H.items():
        cols += [np.real(h).astype(float), np.imag(h).astype(float)]
        names += [f"{s}_re", f"{s}_im"]
        if test.coherence and s in test.coherence:
            cols.append(np.asarray(test.coherence[s], float))
            names.append(f"{s}_coh")
    rows = np.column_stack(cols).tolist()
    text = ",".join(names) + "\n" + "".join(",".join(map(repr, r)) + "\n" for r in rows)
    _atomic_write(path, lambda p: p.write_text(text), lambda: _write_sidecar(path, test))


def _uff_record(x: np.ndarray, data: np.ndarray, id1: str, func_type: int, node: int, spec: int,
                denom: int = 0, units: str = "N") -> dict:
    return {"type": 58, "binary": 0, "id1": id1, "id2": "frictionrt FRF file", "func_type": func_type,
            "rsp_node": node, "rsp_dir": 3, "ref_node": 0, "ref_dir": 3, "abscissa_spacing": 0,
            "abscissa_spec_data_type": SPEC_FREQUENCY, "abscissa_axis_lab": "frequency",
            "abscissa_axis_units_lab": "Hz", "ordinate_spec_data_type": spec,
            "orddenom_spec_data_type": denom, "ordinate_axis_units_lab": units, "x": x, "data": data}


def write_frf_uff(path: str | os.PathLike, test: FRFTest) -> None:
    """``test`` as ``path`` (.uff/.unv, ASCII data sets 58 through pyuff) and its sidecar."""
    import pyuff
    path = Path(path)
    check_test(test)
    x = np.asarray(test.freq_hz, float)
    if np.any(np.diff(np.array([float(f"{v:.5e}") for v in x])) <= 0):
        raise ValueError(f"{path}: frequency lines closer than the 6 significant digits UFF ASCII keeps (E13.5); "
                         "write this test as CSV")
    spec, denom = QUANTITIES[test.quantity][2], EXCITATIONS[test.excitation][1]
    units = f"{QUANTITIES[test.quantity][1]}/{EXCITATIONS[test.excitation][0]}"   # m/s^2/N as before
    sets = [_uff_record(x, np.asarray(h, complex), s, FUNC_FRF, _uff_node(s, j), spec, denom, units)
            for j, (s, h) in enumerate(test.H.items())]
    sets += [_uff_record(x, np.asarray(a, float), name, FUNC_GENERAL, 0, SPEC_FORCE)
             for name, a in zip(AMPLITUDES, (test.F_amp_N, test.drive_amp)) if a is not None]
    sets += [_uff_record(x, np.asarray(g, float), s, FUNC_COHERENCE, _uff_node(s, list(test.H).index(s)), 0, units="")
             for s, g in (test.coherence or {}).items()]
    _atomic_write(path, lambda p: pyuff.UFF(str(p)).write_sets(sets, mode="overwrite"),
                  lambda: _write_sidecar(path, test))


def _uff_node(sensor: str, j: int) -> int:
    """UFF response node of the j-th sensor: 1, 2 for a_tip_meas, a_frf_meas (the two-accelerometer files),
    3 + j for any other."""
    return SENSORS.index(sensor) + 1 if sensor in SENSORS else len(SENSORS) + 1 + j


# --- readers -------------------------------------------------------------------------------------

def read_meta(path: Path) -> dict:
    """The checked sidecar of the data file ``path``; ValueError naming the sidecar."""
    side = sidecar_path(path)
    if not side.is_file():
        raise ValueError(f"{path}: no sidecar {side.name} beside it; write one with the keys "
                         f"{', '.join(SIDECAR_KEYS)} ({FIX_DOC})")
    try:
        meta = json.loads(side.read_text(encoding="utf-8"))
        return check_meta(meta)
    except UnicodeDecodeError:
        raise ValueError(f"{side}: not UTF-8 text; the sidecar is a JSON object ({FIX_DOC})") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{side}: not valid JSON ({exc.msg} at line {exc.lineno}); the sidecar is a JSON "
                         f"object ({FIX_DOC})") from None
    except ValueError as exc:
        raise ValueError(f"{side}: {exc}") from None


def _parse_csv(text: str) -> tuple[np.ndarray, dict, np.ndarray | None, np.ndarray | None, dict | None]:
    lines = text.lstrip("\ufeff").splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise ValueError(f"empty file; the first row is the header freq_hz,<sensor>_re,<sensor>_im,... ({FIX_DOC})")
    header = [h.strip() for h in lines[0].split(",")]
    if header[0] != "freq_hz":
        raise ValueError(f"the header starts with {header[0][:40]!r}, not freq_hz; the header is "
                         f"freq_hz[,F_amp_N][,drive_amp_N],<sensor>_re,<sensor>_im,... ({FIX_DOC})")
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise ValueError(f"header column {dup[:40]!r} appears twice; name each column once")
    for h in header[1:]:
        if h not in AMPLITUDES and not (h.endswith(("_re", "_im")) and FIELD_RE.match(h[:-3])
                                        or h.endswith("_coh") and FIELD_RE.match(h[:-4])):
            raise ValueError(f"unknown header column {h[:40]!r}; columns are freq_hz, F_amp_N, drive_amp_N and "
                             f"<sensor>_re, <sensor>_im (and optionally <sensor>_coh) for each sensor (a lowercase "
                             f"snake_case name, e.g. {', '.join(SENSORS)})")
    sensors = list(dict.fromkeys(h[:-3] for h in header[1:] if h not in AMPLITUDES and not h.endswith("_coh")))
    for s in sensors:
        for part in ("_re", "_im"):
            if s + part not in header:
                raise ValueError(f"column {s}{part} missing (sensor {s} has only the other part of its complex "
                                 f"FRF); give both {s}_re and {s}_im")
    vals = np.empty((len(lines) - 1, len(header)))
    for i, line in enumerate(lines[1:]):
        fields = line.split(",")
        if len(fields) != len(header):
            raise ValueError(f"line {i + 2} has {len(fields)} fields, the header {len(header)}; one value per column")
        for j, f in enumerate(fields):
            try:
                vals[i, j] = float(f)
            except ValueError:
                raise ValueError(f"line {i + 2}, column {header[j]}: {f.strip()[:40]!r} is not a number") from None
    col = {h: vals[:, j] for j, h in enumerate(header)}
    H = {s: col[s + "_re"] + 1j * col[s + "_im"] for s in sensors}
    coh = {h[:-4]: col[h] for h in header[1:] if h.endswith("_coh")}
    return col["freq_hz"], H, col.get("F_amp_N"), col.get("drive_amp_N"), coh or None


def uff_truncation(path: str | os.PathLike) -> int | None:
    """The number of the last line of an ASCII universal file cut short inside a data set (one opened
    by a ``-1`` line and never closed by another), or None if every data set is closed. A binary set
    (58b) is not scanned line by line: None from there on."""
    open_at = None
    n = 0
    with open(path, "rb") as fh:
        for n, raw in enumerate(fh, 1):
            line = raw.rstrip(b"\r\n")
            if line.strip() == b"-1" and len(line) <= 6:
                open_at = n if open_at is None else None
            elif open_at == n - 1 and line.strip().endswith(b"b"):
                return None             # binary data set: its payload is not lines
    return n if open_at is not None else None


def read_uff_sets(path: Path) -> list[dict]:
    import pyuff
    cut = uff_truncation(path)
    if cut is not None:
        raise ValueError(f"truncated after line {cut}: its last data set is not closed by a -1 line (the file was "
                         "cut short in a copy or an export); export the file again")
    # pyuff prints some readers' notes to stdout, numpy may warn on odd numbers: neither may reach the CLI
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            uff = pyuff.UFF(str(path))
            n = uff.get_n_sets()
        except Exception as exc:  # noqa: BLE001 (pyuff raises bare Exception on damaged files)
            raise ValueError(f"not a readable universal file ({str(exc)[:80]}); export the FRFs as UFF data "
                             f"sets 58 ({FIX_DOC})") from None
        sets = []
        for i in range(n):
            try:
                sets.append(uff.read_sets(i))
            except Exception:  # noqa: BLE001
                raise ValueError(f"data set {i + 1} of {n} cannot be parsed (a damaged header line or number); "
                                 f"export the file again ({FIX_DOC})") from None
    sets = [d for d in sets if d.get("type") == 58]
    if not sets:
        raise ValueError(f"no data set 58 (function at nodal DOF) in the file; export the FRFs as UFF data "
                         f"sets 58 ({FIX_DOC})")
    return sets


def _check_characteristics(d: dict, name: str, meta: dict) -> None:
    """A stated ordinate numerator (8, 11, 12) and denominator (13) of an FRF data set agree with
    the sidecar's quantity and excitation (others, 0 = unknown among them, are not statements)."""
    q = meta.get("quantity", OPTIONAL_KEYS["quantity"])
    e = meta.get("excitation", OPTIONAL_KEYS["excitation"])
    by_spec = {v[2]: k for k, v in QUANTITIES.items()}
    num, den = d.get("ordinate_spec_data_type"), d.get("orddenom_spec_data_type")
    if num in by_spec and by_spec[num] != q:
        raise ValueError(f"FRF data set {name}: ordinate data characteristic {num} ({by_spec[num]}), but the sidecar "
                         f"says quantity {q!r}; set the sidecar's quantity to {by_spec[num]!r} or export the file "
                         f"as {q}")
    if den == SPEC_FORCE and e != "force":
        raise ValueError(f"FRF data set {name}: ordinate denominator {SPEC_FORCE} (excitation force), but the sidecar "
                         f"says excitation {e!r}; correct one of them")


def _parse_uff(path: Path, meta: dict) -> tuple[np.ndarray, dict, np.ndarray | None, np.ndarray | None, dict | None]:
    x, H, amp, coh = None, {}, {}, {}
    for d in read_uff_sets(path):
        name = str(d.get("id1", "")).strip()
        ft = d.get("func_type")
        if ft == FUNC_FRF:
            check_sensor_name(name, "FRF data set with ID line 1 (the sensor's name)")
            if d.get("ord_data_type") not in (5, 6):
                raise ValueError(f"FRF data set {name}: real ordinate (type {d.get('ord_data_type')}); an FRF is "
                                 "complex (ordinate data type 5 or 6)")
            _check_characteristics(d, name, meta)
            target = H
        elif ft == FUNC_GENERAL and name in AMPLITUDES or ft == FUNC_COHERENCE:
            if d.get("ord_data_type") not in (2, 4):
                raise ValueError(f"data set {name}: complex ordinate; an amplitude or a coherence is real (type 2 "
                                 "or 4)")
            target = amp if ft == FUNC_GENERAL else coh
        else:
            raise ValueError(f"data set 58 {name[:40]!r} has function type {ft!r}; the file holds FRFs (type "
                             f"{FUNC_FRF}) and coherences (type {FUNC_COHERENCE}) of the sensors and amplitudes (type "
                             f"{FUNC_GENERAL}) named {' or '.join(AMPLITUDES)}")
        if d.get("abscissa_spec_data_type") != SPEC_FREQUENCY:
            raise ValueError(f"data set {name}: abscissa data type {d.get('abscissa_spec_data_type')!r}, not "
                             f"{SPEC_FREQUENCY} (frequency in Hz)")
        if name in target:
            raise ValueError(f"two data sets for {name}; give one per sensor")
        xd, yd = np.asarray(d.get("x"), float), np.asarray(d.get("data"))
        if xd.shape != yd.shape or xd.ndim != 1:
            raise ValueError(f"data set {name}: {xd.size} abscissa values for {yd.size} ordinate values")
        if x is None:
            x = xd
        elif xd.shape != x.shape or not np.array_equal(xd, x, equal_nan=True):
            raise ValueError(f"data set {name} has other frequency lines than the first data set; give every "
                             "data set the same lines")
        target[name] = yd.astype(complex) if target is H else yd.astype(float)
    if not H:
        raise ValueError(f"no FRF data set (function type {FUNC_FRF}); give one per sensor")
    return x, H, amp.get("F_amp_N"), amp.get("drive_amp_N"), coh or None


def read_frf(path: str | os.PathLike) -> FRFTest:
    """One test from ``path`` (.csv, .uff or .unv by suffix) and its sidecar; ValueError naming the
    file, the problem and the fix."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise ValueError(f"{path}: suffix {path.suffix!r}; FRF files are {', '.join(SUFFIXES)} ({FIX_DOC})")
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    meta = read_meta(path)
    try:
        if path.suffix.lower() == ".csv":
            try:
                text = path.read_text(encoding="utf-8")
            except UnicodeDecodeError:
                raise ValueError("not UTF-8 text; an FRF CSV is plain text") from None
            freq, H, F_amp, drive, coh = _parse_csv(text)
        else:
            freq, H, F_amp, drive, coh = _parse_uff(path, meta)
        check_lines(freq, H, F_amp, drive, meta, coh)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    return FRFTest(path.stem, freq, H, F_amp, drive, meta, coh)


def frf_files(folder: str | os.PathLike) -> list[Path]:
    """The FRF data files of a folder (suffixes ``SUFFIXES``), sorted by name."""
    return sorted(p for p in Path(folder).iterdir() if p.is_file() and p.suffix.lower() in SUFFIXES
                  and not p.name.startswith("."))


def load_frf_folder(folder: str | os.PathLike) -> list[FRFTest]:
    """Every FRF file of ``folder`` read (read_frf); ValueError naming the folder or the file."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: {'not a folder' if folder.exists() else 'no such folder'}; give a folder "
                         "of FRF files (frictionrt rig --frf-files -o DIR writes one)")
    files = frf_files(folder)
    if not files:
        raise ValueError(f"{folder}: no FRF files ({', '.join('*' + s for s in SUFFIXES)}) in the folder")
    stems = [p.stem for p in files]
    dup = next((s for s in stems if stems.count(s) > 1), None)
    if dup is not None:
        raise ValueError(f"{folder}: two data files named {dup}.* share the sidecar {dup}.json; keep one format "
                         "per test or rename one")
    return [read_frf(p) for p in files]
