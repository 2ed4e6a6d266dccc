"""FRFs as analysers export them, imported into a folder of FRF files (rt.log.frf_files) that
``frictionrt diagnose`` and ``frictionrt validate`` read: ``import_frf(sources, out, ...)``.

Formats (by suffix):

* text ``.csv`` / ``.txt`` / ``.tsv`` / ``.dat``: one row per frequency line, separated by ``;``,
  tab, ``,`` or blanks (the last line decides), decimal point or decimal comma, headers quoted or
  not, comment lines (``#``, ``%``, ``!``, ``//``) and a preamble before the header skipped (but for
  its ``Unit: ...`` and ``Quantity: ...`` lines, which state the FRFs' unit and quantity). The
  header names the frequency first (``freq``, ``frequency``, ``f``, ``omega``, ``w``, with its unit
  in the name or in brackets: ``Frequency [Hz]``, ``"omega (rad/s)"``, ``freq_hz``), then per sensor
  two parts of its complex FRF, real and imaginary (``re``, ``real``, ``im``, ``imag``) or magnitude
  and phase (``mag``, ``magnitude``, ``abs``, ``amplitude``; ``phase``, ``arg``, ``angle``), and
  optionally its coherence (``coh``): ``"a1 Real [(m/s^2)/N]"``, ``a_tip_meas_im``, ``Mag(a1) [dB]``,
  ``a1 phase [deg]``. A magnitude is linear unless its unit says dB (20 log10).
* universal file ``.uff`` / ``.unv``: data sets 58 of function type 4 (FRF), read by pyuff; the
  sensor named by ID line 1 (else its response node and direction), the quantity by the ordinate's
  data characteristic (8, 11, 12: receptance, mobility, accelerance) and the excitation by the
  denominator's (13: force), in SI unless the ordinate's unit label says otherwise; the abscissa in
  Hz unless its label says rad/s.
* MATLAB ``.mat``: v5 through scipy.io.loadmat, v7.3 (HDF5) through h5py where installed. The
  variables are named as the text headers' columns (a frequency vector, then per sensor a complex
  vector, or the two parts ``<sensor>_re``/``_im``, ``_mag``/``_phase``); or one complex matrix
  ``H`` (or ``frf``), a column per sensor, named by a cell array ``sensors``. A string variable
  ``unit`` gives the FRFs' unit, ``quantity`` their quantity.

What a file does not say is given by a keyword (a flag of ``frictionrt import-frf``, the same name
with ``-``): ``unit`` (the FRF's unit, ``UNITS``: e.g. ``(m/s^2)/N``, ``g/N``, ``(mm/s)/N``, ``m/V``)
or ``quantity`` (accelerance, mobility or receptance in SI units per newton), ``frequency_unit``
(``hz`` or ``rad/s``), ``phase_unit`` (``deg`` or ``rad``), ``sensor_positions`` {sensor: x [m]},
``excitation_x`` [m], ``fn1`` (the held bolt force F_N1 [N], 0 without an adaptive screw; one per
source or one for all) and, for an FRF per volt, ``force_scale`` [N/V] (the shaker's force per drive
volt: the FRF is divided by it and stored per newton) or ``drive_voltage`` [V] (the drive's
amplitude: the FRF stays per volt). A missing one is refused in one line naming it and its flag
(``MissingInput``); a flag that contradicts the file is refused too. ``sensor_names`` renames the
sensors in the file's order (else a name is made from the file's: lowercase snake_case). A leading
0 Hz line (an analyser's DC line) is dropped and counted in the result.

The response is stored in SI: H_SI = c H_file, c the unit's factor (``UNITS``; g = 9.80665 m/s^2).
The frequency in Hz: f = omega / (2 pi). From magnitude and phase: H = |H| exp(i phi).

The output folder holds per source ``<stem>.csv`` and its sidecar ``<stem>.json`` (written by
rt.log.frf_files.write_frf_csv, bit-exact), and is written whole or not at all: a temporary folder
beside it, renamed in once every source was read and written (``force``: an existing folder is
replaced, and kept if the import fails).

Length: one importer; its three readers (text, UFF, MAT) share the name classifier and the units,
and the one finishing step turns what each read into a test; split, each reader would import the
classifier and the finisher the readers.
"""
from __future__ import annotations

import csv
import math
import os
import re
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from frictionrt.rt.log.frf_files import (
    EXCITATIONS,
    FORMAT,
    FRFTest,
    QUANTITIES,
    check_sensor_name,
    check_test,
    frf_unit,
    read_frf,
    read_uff_sets,
    write_frf_csv,
)

TEXT_SUFFIXES = (".csv", ".txt", ".tsv", ".dat")
UFF_SUFFIXES = (".uff", ".unv")
MAT_SUFFIXES = (".mat",)
IMPORT_SUFFIXES = TEXT_SUFFIXES + UFF_SUFFIXES + MAT_SUFFIXES
G_M_S2 = 9.80665                                 # standard gravity [m/s^2]
NUMERATORS = {"m/s^2": ("accelerance", 1.0), "mm/s^2": ("accelerance", 1e-3), "g": ("accelerance", G_M_S2),
              "m/s": ("mobility", 1.0), "mm/s": ("mobility", 1e-3),
              "m": ("receptance", 1.0), "mm": ("receptance", 1e-3), "um": ("receptance", 1e-6)}
"""A response unit -> (quantity, factor to SI)."""
DENOMINATORS = {"n": "force", "v": "drive_voltage"}
UNITS = tuple(f"{n}/{d.upper()}" for n in NUMERATORS for d in DENOMINATORS)
"""The FRF units understood (spelled with or without parentheses, ** or ^, ² or 2, µ or u)."""
FREQUENCY_UNITS = {"hz": 1.0, "rad/s": 1.0 / (2.0 * math.pi)}   # unit -> factor to Hz
PHASE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}               # unit -> factor to rad
QUANTITY_WORDS = {"accelerance": "accelerance", "inertance": "accelerance", "mobility": "mobility",
                  "receptance": "receptance", "compliance": "receptance"}
FREQ_WORDS = {"freq", "frequency", "frequenz", "f", "omega", "w", "hz"}
PARTS = {"re": "re", "real": "re", "im": "im", "imag": "im", "imaginary": "im", "mag": "mag", "magnitude": "mag",
         "abs": "mag", "amp": "mag", "amplitude": "mag", "modulus": "mag", "phase": "phase", "phi": "phase",
         "arg": "phase", "angle": "phase", "coh": "coh", "coherence": "coh"}
COMMENTS = ("#", "%", "!", "//")


class MissingInput(ValueError):
    """What a file does not say and no keyword (flag) gave: the message names each and its flag."""


@dataclass
class _Sensor:
    parts: dict = field(default_factory=dict)   # re, im, mag, phase, coh -> (n,) float
    mag_db: bool = False
    phase_unit: str | None = None


@dataclass
class _Raw:
    """One source as read: what it says (None: it does not say)."""
    freq: np.ndarray
    freq_unit: str | None
    sensors: dict                                # file's name -> _Sensor, in the file's order
    unit: str | None = None                     # the FRF's unit as the file writes it
    quantity: str | None = None
    excitation: str | None = None


@dataclass(frozen=True)
class ImportResult:
    """What ``import_frf`` wrote: the folder and, per source, its test."""
    folder: Path
    tests: tuple                                 # per source a dict (``to_dict``)

    @property
    def files(self) -> list[Path]:
        """The FRF data files written (each with its sidecar .json)."""
        return [self.folder / t["file"] for t in self.tests]

    def to_dict(self) -> dict:
        """{"folder", "tests": [{"source", "file", "sensors": {file's name: sensor}, "lines", "f_min_hz",
        "f_max_hz", "quantity", "excitation", "unit", "dropped_dc_line"}]}: what --json prints."""
        return {"folder": str(self.folder), "tests": [dict(t) for t in self.tests]}

    def __str__(self) -> str:
        out = [f"{len(self.tests)} FRF file{'s' if len(self.tests) != 1 else ''} in {self.folder}:"]
        for t in self.tests:
            names = ", ".join(s if s == k else f"{s} (from {k!r})" for k, s in t["sensors"].items())
            out.append(f"  {t['file']} from {t['source']}: {t['lines']} lines {t['f_min_hz']:.6g}-{t['f_max_hz']:.6g} "
                       f"Hz, {t['quantity']} [{t['unit']}], sensors {names}"
                       + ("; its 0 Hz line dropped" if t["dropped_dc_line"] else ""))
        return "\n".join(out)


# --- units ---------------------------------------------------------------------------------------

def _norm_unit(text: str) -> str:
    t = text.strip().lower().replace(" ", "").replace("²", "^2").replace("**", "^").replace("µ", "u")
    t = t.replace("μ", "u").replace("(", "").replace(")", "")
    return re.sub(r"s2(?=/|$)", "s^2", t)


def parse_unit(text: str) -> tuple[str, str, float]:
    """An FRF's unit (``UNITS``, e.g. ``(m/s^2)/N``, ``g/N``, ``mm/s/V``) as (quantity, excitation,
    factor to SI: H_SI = factor H); ValueError naming the units understood."""
    t = _norm_unit(text)
    num, _, den = t.rpartition("/")
    if num in NUMERATORS and den in DENOMINATORS:
        q, c = NUMERATORS[num]
        return q, DENOMINATORS[den], c
    raise ValueError(f"FRF unit {text.strip()[:40]!r} is not one of {', '.join(UNITS)}")


def _frequency_unit(text: str | None, tokens: list[str]) -> str | None:
    t = _norm_unit(text or "")
    if t in ("hz", "1/s") or t == "" and "hz" in tokens:
        return "hz"
    if t in ("rad/s", "rad/sec") or t == "" and ("rad" in tokens or tokens[:1] in (["omega"], ["w"])):
        return "rad/s"
    return None


def _phase_unit(text: str | None, tokens: list[str]) -> str | None:
    t = _norm_unit(text or "")
    if t in ("deg", "degree", "degrees", "°") or t == "" and ({"deg", "degree", "degrees"} & set(tokens)):
        return "deg"
    if t in ("rad", "radian", "radians") or t == "" and "rad" in tokens:
        return "rad"
    return None


# --- names ---------------------------------------------------------------------------------------

def _split_unit(h: str) -> tuple[str, str | None]:
    """"a1 Real [(m/s^2)/N]" -> ("a1 Real", "(m/s^2)/N"); a trailing [...] or balanced (...)."""
    h = h.strip()
    if h.endswith("]") and "[" in h:
        i = h.rindex("[")
        return h[:i].strip(), h[i + 1:-1].strip()
    if h.endswith(")"):
        depth = 0
        for i in range(len(h) - 1, -1, -1):
            depth += {")": 1, "(": -1}.get(h[i], 0)
            if depth == 0:
                inner = h[i + 1:-1].strip()
                # "Re(a1)" is a part of a sensor, not a unit: a unit has a / or is a known word
                if "/" in inner or _norm_unit(inner) in ("hz", "deg", "rad", "db", "°"):
                    return h[:i].strip(), inner
                break
    return h, None


def _tokens(name: str) -> list[str]:
    return [t for t in re.split(r"[^0-9a-z]+", name.lower()) if t]


def snake_name(name: str) -> str:
    """A file's sensor name as a sensor name of the FRF files: lowercase snake_case, ``s_`` before a
    leading digit (``"Acc 1 +Z"`` -> ``acc_1_z``, ``"1"`` -> ``s_1``)."""
    t = "_".join(_tokens(name)) or "h"
    return f"s_{t}" if t[0].isdigit() else t


def _classify(name: str) -> tuple[str, str | None, list[str], str | None]:
    """A column or variable name -> (kind: "freq" | a part of PARTS | "", sensor base name, tokens,
    unit text). The quantity word, if any, is the last token of the list "quantity:<word>"."""
    base, unit = _split_unit(name)
    tok = _tokens(base)
    quantity = [QUANTITY_WORDS[t] for t in tok if t in QUANTITY_WORDS]
    tok = [t for t in tok if t not in QUANTITY_WORDS and t != "part"]
    db = unit is not None and _norm_unit(unit) == "db" or bool(tok) and tok[-1] == "db"
    tok = tok[:-1] if tok and tok[-1] == "db" else tok
    part = None
    for pos in (-1, 0) if tok else ():
        t = tok[pos]
        if t in PARTS:
            part = PARTS[t]
            tok = tok[:-1] if pos == -1 else tok[1:]
            break
    if db:
        tok.append("db")
    core = [t for t in tok if t not in ("db", "deg", "rad", "degree", "degrees")]
    if part is None and core and (core[0] in FREQ_WORDS or set(core) <= FREQ_WORDS | {"rad", "s"}):
        return "freq", None, core, unit
    return (part or ""), "_".join(core), [*core, *(f"quantity:{q}" for q in quantity)], unit


def _add_part(raw_sensors: dict, name: str, part: str, base: str, tok: list[str], unit: str | None,
              values: np.ndarray, where: str) -> str | None:
    """Adds one part column to its sensor; returns the FRF unit text it states (re, im, mag), if any."""
    s = raw_sensors.setdefault(base, _Sensor())
    if part in s.parts:
        raise ValueError(f"{where}: two {part} columns for sensor {base or 'h'!r} ({name!r}); name each once")
    s.parts[part] = values
    if part == "phase":
        s.phase_unit = _phase_unit(unit, tok)
        return None
    if part == "mag" and (unit is not None and _norm_unit(unit) == "db" or "db" in tok):
        s.mag_db = True
        return None
    return unit if part in ("re", "im", "mag") else None


def _quantity_of(tok_lists) -> str | None:
    qs = {t.split(":", 1)[1] for tok in tok_lists for t in tok if t.startswith("quantity:")}
    if len(qs) > 1:
        raise ValueError(f"the columns name several quantities ({', '.join(sorted(qs))}); import one quantity "
                         "per file")
    return qs.pop() if qs else None


def _columns_to_raw(names: list[str], cols: list[np.ndarray], where: str) -> _Raw:
    """Named columns (a header's or a .mat file's variables) -> _Raw; the frequency first."""
    kind, _, tok, unit = _classify(names[0])
    if kind != "freq" and unit is not None and _frequency_unit(unit, []) is not None:
        kind = "freq"
    if kind != "freq":
        raise ValueError(f"{where}: the first column {names[0][:40]!r} is not a frequency; the first column is the "
                         "frequency (e.g. \"Frequency [Hz]\", freq_hz, \"omega (rad/s)\")")
    freq_unit = _frequency_unit(unit, tok)
    sensors, units, toks = {}, set(), []
    for name, values in zip(names[1:], cols[1:]):
        part, base, tok, unit = _classify(name)
        if part not in ("re", "im", "mag", "phase", "coh"):
            raise ValueError(f"{where}: column {name[:40]!r} is neither the frequency nor a part of a sensor's "
                             "FRF (re, im, mag, phase, coh); drop it or name it e.g. \"a1 Real\", a1_phase")
        toks.append(tok)
        u = _add_part(sensors, name, part, base, tok, unit, values, where)
        if u is not None:
            units.add(u)
    if len(units) > 1:
        raise ValueError(f"{where}: the columns give several FRF units ({', '.join(sorted(units))}); import one unit "
                         "per file")
    return _Raw(cols[0], freq_unit, sensors, units.pop() if units else None, _quantity_of(toks))


# --- text tables ---------------------------------------------------------------------------------

def _decode(data: bytes) -> str:
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return data.decode("utf-16")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("cp1252", errors="replace")    # analysers' Windows exports (deg sign, u)


def _number(text: str, decimal_comma: bool) -> float:
    t = text.strip().strip('"').strip()
    if decimal_comma:
        t = t.replace(".", "").replace(",", ".") if "." in t and "," in t else t.replace(",", ".")
    return float(t)


def _split(line: str, sep: str | None) -> list[str]:
    return line.split() if sep is None else next(csv.reader([line], delimiter=sep, quotechar='"'))


def _read_text(path: Path) -> _Raw:
    lines = _decode(path.read_bytes()).splitlines()
    body = [(i, ln) for i, ln in enumerate(lines, 1) if ln.strip() and not ln.lstrip().startswith(COMMENTS)]
    if not body:
        raise ValueError(f"{path}: empty file; a header and one row per frequency line")
    last = body[-1][1]
    # the separator: tab, ';', ',' (but not between blank-separated numbers with decimal commas), blanks
    sep = "\t" if "\t" in last else ";" if ";" in last else "," if "," in last and len(last.split()) == 1 else None
    # decimal comma: a separator other than ',' with commas in the numbers, or quoted numbers with commas
    sample = _split(last, sep)
    decimal_comma = any("," in f for f in sample)
    rows = []
    for i, ln in body:
        f = _split(ln, sep)
        try:
            rows.append((i, f, [_number(x, decimal_comma) for x in f]))
        except ValueError:
            rows.append((i, f, None))
    # the data: the longest run of numeric rows at the end of the file
    k = len(rows)
    while k > 0 and rows[k - 1][2] is not None and len(rows[k - 1][1]) == len(sample):
        k -= 1
    if k == len(rows):
        i, f, _ = rows[-1]
        raise ValueError(f"{path}: line {i} is not a row of numbers ({' '.join(f)[:40]!r}); the file ends with one "
                         "row per frequency line")
    if k == 0:
        raise ValueError(f"{path}: no header line before the data; give the columns' names in a first line "
                         "(e.g. \"Frequency [Hz]\";\"a1 Real\";\"a1 Imag\")")
    hi, header, _ = rows[k - 1]
    if sep is None and len(header) != len(sample):     # blank-separated names with blanks: 2 or more apart
        header = re.split(r"\s{2,}|\t", lines[hi - 1].strip())
    if len(header) != len(sample):
        bad = next((r for r in rows[k - 1::-1] if r[2] is None), rows[k - 1])
        raise ValueError(f"{path}: line {bad[0]} has {len(bad[1])} fields, the data rows {len(sample)}; "
                         "one header name per column")
    data = np.array([r[2] for r in rows[k:]], float)
    raw = _columns_to_raw([h.strip().strip('"').strip() for h in header], list(data.T), str(path))
    for ln in lines[:hi - 1]:                     # a preamble's "Unit: ..." and "Quantity: ..." lines
        m = re.match(r"^\W*(units?|quantity)\s*[:=]\s*(.+?)\s*$", ln.strip().strip('"'), re.IGNORECASE)
        if m and m.group(1).lower().startswith("unit") and raw.unit is None:
            raw.unit = m.group(2).strip('"; \t')
        elif m and m.group(1).lower() == "quantity" and raw.quantity is None:
            raw.quantity = QUANTITY_WORDS.get(m.group(2).strip('"; \t').lower())
    return raw


# --- universal files -----------------------------------------------------------------------------

def _read_uff(path: Path) -> _Raw:
    try:
        sets = [d for d in read_uff_sets(path) if d.get("func_type") == 4]
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    if not sets:
        raise ValueError(f"{path}: no FRF data set (58 of function type 4) in the file; export the FRFs as "
                         "UFF data sets 58")
    by_spec = {v[2]: k for k, v in QUANTITIES.items()}
    sensors, quantities, excitations, units, freq_units = {}, set(), set(), set(), set()
    x = None
    for d in sets:
        name = str(d.get("id1", "")).strip() or f"node_{d.get('rsp_node', 0)}_{d.get('rsp_dir', 0)}"
        xd, yd = np.asarray(d.get("x"), float), np.asarray(d.get("data"))
        if x is None:
            x = xd
        elif xd.shape != x.shape or not np.array_equal(xd, x):
            raise ValueError(f"{path}: data set {name[:40]!r} has other frequency lines than the first; export "
                             "every FRF on the same lines")
        if name in sensors:
            raise ValueError(f"{path}: two FRF data sets named {name[:40]!r}; give each sensor its own ID line 1")
        if not np.iscomplexobj(yd):
            raise ValueError(f"{path}: FRF data set {name[:40]!r} is real; an FRF is complex (ordinate type 5 or 6)")
        sensors[name] = _Sensor({"re": yd.real.astype(float), "im": yd.imag.astype(float)})
        if d.get("ordinate_spec_data_type") in by_spec:
            quantities.add(by_spec[d["ordinate_spec_data_type"]])
        if d.get("orddenom_spec_data_type") == EXCITATIONS["force"][1] and EXCITATIONS["force"][1]:
            excitations.add("force")
        label = str(d.get("ordinate_axis_units_lab", "")).strip()
        if label:
            try:
                parse_unit(label)
                units.add(label)
            except ValueError:
                pass
        freq_units.add(_frequency_unit(str(d.get("abscissa_axis_units_lab", "")).strip(), []) or "hz")
    if len(quantities) > 1 or len(units) > 1 or len(freq_units) > 1:
        raise ValueError(f"{path}: the FRF data sets differ in quantity or unit; import one quantity and unit per file")
    unit = units.pop() if units else None
    q = quantities.pop() if quantities else None
    e = excitations.pop() if excitations else None
    if unit is None and q is not None and e == "force":
        unit = frf_unit(q, "force")              # stated by the data characteristics, SI (the UFF default)
    return _Raw(x, freq_units.pop(), sensors, unit, q, e)


# --- MATLAB --------------------------------------------------------------------------------------

def _mat_text(v) -> str | None:
    if isinstance(v, str):
        return v
    a = np.asarray(v)
    if a.dtype.kind == "U":
        return "".join(a.ravel().tolist()) if a.ndim else str(a)
    return None


def _mat_v5(path: Path) -> dict:
    import scipy.io
    try:
        m = scipy.io.loadmat(str(path), squeeze_me=True, chars_as_strings=True)
    except NotImplementedError:
        raise _V73 from None
    except Exception as exc:  # noqa: BLE001 (scipy raises several kinds on damaged files)
        raise ValueError(f"{path}: not a readable MATLAB file ({str(exc)[:80]}); save it with save(..., '-v7') "
                         "or '-v7.3'") from None
    out = {}
    for k, v in m.items():
        if k.startswith("__"):
            continue
        if isinstance(v, np.ndarray) and v.dtype == object:   # a cell array of strings
            out[k] = [str(_mat_text(x) or x) for x in v.ravel()]
        else:
            out[k] = _mat_text(v) if _mat_text(v) is not None else np.asarray(v)
    return out


class _V73(Exception):
    """A v7.3 (HDF5) MAT file."""


def _mat_v73(path: Path) -> dict:
    try:
        import h5py
    except ImportError:
        raise ValueError(f"{path}: a MATLAB v7.3 (HDF5) file needs h5py (pip install 'frictionrt[mat73]'), or save "
                         "it with save(..., '-v7')") from None
    out = {}
    with h5py.File(str(path), "r") as fh:
        for k, ds in fh.items():
            if k.startswith("#") or not isinstance(ds, h5py.Dataset):
                continue
            cls = ds.attrs.get("MATLAB_class", b"")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            a = ds[()]
            if cls == "char":
                out[k] = "".join(map(chr, np.asarray(a).ravel()))
            elif cls == "cell":
                out[k] = ["".join(map(chr, np.asarray(fh[r][()]).ravel())) for r in np.asarray(a).ravel()]
            else:
                if a.dtype.names and {"real", "imag"} <= set(a.dtype.names):
                    a = a["real"] + 1j * a["imag"]
                out[k] = np.asarray(a).T.squeeze()         # MATLAB writes column-major: transposed
    return out


def _read_mat(path: Path, sensor_names) -> _Raw:
    with open(path, "rb") as fh:
        head = fh.read(520)
    hdf5 = b"\x89HDF\r\n\x1a\n"
    try:
        m = _mat_v73(path) if head.startswith(b"MATLAB 7.3") or hdf5 in (head[:8], head[512:520]) else _mat_v5(path)
    except _V73:
        m = _mat_v73(path)
    unit = m.pop("unit", None) or m.pop("units", None)
    quantity = m.pop("quantity", None)
    names = m.pop("sensors", None)
    if isinstance(names, str):
        names = [names]
    if quantity is not None and (not isinstance(quantity, str) or quantity.lower() not in QUANTITY_WORDS):
        raise ValueError(f"{path}: variable quantity is {str(quantity)[:40]!r}; give one of {', '.join(QUANTITIES)}")
    arrays = {k: v for k, v in m.items() if isinstance(v, np.ndarray) and v.dtype.kind in "fciu" and v.size > 1}
    freq = [k for k in arrays if _classify(k)[0] == "freq"]
    if len(freq) != 1:
        raise ValueError(f"{path}: {'no' if not freq else 'several'} frequency variable(s) "
                         f"({', '.join(freq) or 'none of freq_hz, freq, f, omega, w'}); give one vector of the "
                         "frequency lines")
    f = arrays.pop(freq[0]).astype(float).ravel()
    names_cols = [freq[0]]
    cols = [f]
    matrix = [k for k in arrays if k.lower() in ("h", "frf") and arrays[k].ndim == 2]
    if matrix:
        Hm = arrays.pop(matrix[0])
        Hm = Hm if Hm.shape[0] == len(f) else Hm.T
        if Hm.shape[0] != len(f):
            raise ValueError(f"{path}: {matrix[0]} has shape {Hm.shape}, the frequency lines {len(f)}")
        labels = list(names) if names is not None else (list(sensor_names) if sensor_names else
                                                         [f"h{j + 1}" for j in range(Hm.shape[1])])
        if len(labels) != Hm.shape[1]:
            raise ValueError(f"{path}: {len(labels)} sensor names for the {Hm.shape[1]} columns of {matrix[0]}; name "
                             "each column once")
        for j, s in enumerate(labels):
            arrays[f"{s}_re"], arrays[f"{s}_im"] = Hm[:, j].real, Hm[:, j].imag
    for k, v in arrays.items():
        v = v.ravel()
        if len(v) != len(f):
            raise ValueError(f"{path}: variable {k} has {len(v)} values, the frequency lines {len(f)}; give one "
                             "value per line")
        if np.iscomplexobj(v):
            names_cols += [f"{k}_re", f"{k}_im"]
            cols += [v.real.astype(float), v.imag.astype(float)]
        else:
            names_cols.append(k)
            cols.append(v.astype(float))
    raw = _columns_to_raw(names_cols, cols, str(path))
    if unit is not None:
        raw.unit = str(unit)
    if quantity is not None:
        raw.quantity = QUANTITY_WORDS[quantity.lower()]
    return raw


# --- from what was read to an FRF test -----------------------------------------------------------

def _read_source(path: str | os.PathLike, sensor_names=None) -> _Raw:
    """What one exported file says (module docstring), before any keyword; ValueError naming the
    file, the problem and the fix."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in IMPORT_SUFFIXES:
        raise ValueError(f"{path}: suffix {path.suffix!r}; import-frf reads {', '.join(IMPORT_SUFFIXES)}")
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    if suffix in UFF_SUFFIXES:
        return _read_uff(path)
    if suffix in MAT_SUFFIXES:
        return _read_mat(path, sensor_names)
    return _read_text(path)


def _agree(path, what: str, stated, given, flag: str):
    """The file's ``stated`` value, or the keyword's ``given``; ValueError if both and they differ."""
    if stated is not None and given is not None and stated != given:
        raise ValueError(f"{path}: the file says {what} {stated}, {flag} gives {given}; drop {flag} or correct it")
    return stated if stated is not None else given


def _complex(path, name: str, s: _Sensor, phase_unit: str | None) -> np.ndarray:
    p = s.parts
    if "re" in p and "im" in p and not ({"mag", "phase"} & set(p)):
        return p["re"] + 1j * p["im"]
    if "mag" in p and "phase" in p and not ({"re", "im"} & set(p)):
        mag = 10.0 ** (p["mag"] / 20.0) if s.mag_db else p["mag"]
        return mag * np.exp(1j * PHASE_UNITS[phase_unit] * p["phase"])
    raise ValueError(f"{path}: sensor {name or 'h'!r} has the parts {', '.join(sorted(p))}; give real and imaginary "
                     "or magnitude and phase")


def import_frf(sources, out, *, unit: str | None = None, quantity: str | None = None,
               frequency_unit: str | None = None, phase_unit: str | None = None, sensor_names=None,
               sensor_positions: dict | None = None, excitation_x: float | None = None, fn1=None,
               force_scale: float | None = None, drive_voltage: float | None = None,
               amplitude: float | None = None, description: str | None = None,
               force: bool = False) -> ImportResult:
    """Import exported FRF files (module docstring) into the new folder ``out``.

    Parameters
    ----------
    sources : path or list of paths, one test each (.csv .txt .tsv .dat .uff .unv .mat).
    out : the folder to create (refused if it exists, unless ``force``).
    unit, quantity, frequency_unit, phase_unit, sensor_names, sensor_positions, excitation_x, fn1,
    force_scale, drive_voltage : what the files do not say (module docstring); units m, N, N/V, V.
    amplitude : the excitation's amplitude [N] (sidecar amplitude_n), or None (not known).
    description : the sidecar's description (default: where it was imported from).

    Returns the ``ImportResult``. Raises ``MissingInput`` (a ValueError) naming what no file says and
    the flag that gives it, ValueError for a file that cannot be read or a keyword that contradicts
    it; nothing is written then.
    """
    srcs = [Path(sources)] if isinstance(sources, (str, os.PathLike)) else [Path(s) for s in sources]
    out = Path(out)
    if not srcs:
        raise ValueError("no source file; give at least one exported FRF file")
    if out.exists() and not force:
        raise ValueError(f"{out}: exists; pass --force to replace it as a whole, or give a new folder")
    for key, val, allowed, flag in ((quantity, quantity, QUANTITIES, "--quantity"),
                                    (frequency_unit, frequency_unit, FREQUENCY_UNITS, "--frequency-unit"),
                                    (phase_unit, phase_unit, PHASE_UNITS, "--phase-unit")):
        if val is not None and val not in allowed:
            raise ValueError(f"{flag} {val!r}; give one of {', '.join(allowed)}")
    if unit is not None and quantity is not None:
        raise ValueError("--unit and --quantity both given; --quantity Q means Q in SI units per newton: give one")
    if unit is not None:
        parse_unit(unit)
    if force_scale is not None and drive_voltage is not None:
        raise ValueError("--force-scale and --drive-voltage both given; --force-scale stores the FRF per newton, "
                         "--drive-voltage keeps it per volt: give one")
    for name, v in (("--force-scale", force_scale), ("--drive-voltage", drive_voltage), ("--amplitude", amplitude)):
        if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ValueError(f"{name} {v!r}; give a positive number")
    fn1s = list(fn1) if isinstance(fn1, (list, tuple)) else [fn1] * len(srcs)
    if len(fn1s) == 1 and len(srcs) > 1:
        fn1s = fn1s * len(srcs)
    if len(fn1s) != len(srcs):
        raise ValueError(f"--fn1 gives {len(fn1s)} values for {len(srcs)} sources; give one, or one per source")
    stems = [snake_name(p.stem) for p in srcs]
    dup = next((s for s in stems if stems.count(s) > 1), None)
    if dup is not None:
        raise ValueError(f"two sources would be written as {dup}.csv; rename one of them")
    tests, rows = [], []
    for src, stem, F_N1 in zip(srcs, stems, fn1s):
        test, row = _one(src, stem, F_N1, unit=unit, quantity=quantity, frequency_unit=frequency_unit,
                         phase_unit=phase_unit, sensor_names=sensor_names, sensor_positions=sensor_positions,
                         excitation_x=excitation_x, force_scale=force_scale, drive_voltage=drive_voltage,
                         amplitude=amplitude, description=description)
        tests.append(test)
        rows.append(row)
    had = {s for t in tests for s in t.H}
    extra = [n for n in (sensor_positions or {}) if n not in had]
    if extra:
        raise ValueError(f"--sensor-positions places {', '.join(extra)}, which no source has (their sensors: "
                         f"{', '.join(sorted(had))}); drop it or rename the sensors by --sensor-names")
    _write_folder(out, tests, force)
    return ImportResult(out, tuple(rows))


def _one(src: Path, stem: str, F_N1, *, unit, quantity, frequency_unit, phase_unit, sensor_names,
         sensor_positions, excitation_x, force_scale, drive_voltage, amplitude, description):
    """One source -> (FRFTest, its row of the result)."""
    raw = _read_source(src, sensor_names)
    missing = []
    f_unit = _agree(src, "the frequency in", raw.freq_unit, frequency_unit, "--frequency-unit")
    if f_unit is None:
        missing.append("the frequency's unit (--frequency-unit hz or rad/s)")
    needs_phase = [k for k, s in raw.sensors.items() if "phase" in s.parts]
    p_units = {s.phase_unit for k, s in raw.sensors.items() if k in needs_phase and s.phase_unit is not None}
    if len(p_units) > 1:
        raise ValueError(f"{src}: the phase columns are in several units ({', '.join(sorted(p_units))}); import one")
    p_unit = _agree(src, "the phase in", p_units.pop() if p_units else None, phase_unit, "--phase-unit")
    if needs_phase and p_unit is None:
        missing.append("the phase's unit (--phase-unit deg or rad)")
    given_unit = unit if unit is not None else (frf_unit(quantity, "force") if quantity is not None else None)
    if raw.unit is not None:
        try:
            q, exc, c = parse_unit(raw.unit)
        except ValueError as e:
            if given_unit is None:
                raise ValueError(f"{src}: {e}; give the unit by --unit") from None
            q, exc, c = parse_unit(given_unit)
        else:
            if given_unit is not None and parse_unit(given_unit) != (q, exc, c):
                raise ValueError(f"{src}: the file says the FRF is in {raw.unit}, the flags give {given_unit}; drop "
                                 "--unit/--quantity or correct it")
    elif given_unit is not None:
        q, exc, c = parse_unit(given_unit)
    else:
        q = exc = c = None
        said = f" (the file says {raw.quantity} but not its unit)" if raw.quantity else ""
        missing.append(f"the FRF's unit{said} (--unit, e.g. '(m/s^2)/N', 'g/N', '(m/s)/V'; or --quantity "
                       "accelerance|mobility|receptance for SI units per newton)")
    if q is not None:
        _agree(src, "quantity", raw.quantity, q, "--unit/--quantity")
        _agree(src, "excitation", raw.excitation, exc, "--unit/--quantity")
    if exc == "drive_voltage" and force_scale is None and drive_voltage is None:
        missing.append("what a volt of the drive is (the FRF is per volt: --force-scale N_PER_V to store it per "
                       "newton, or --drive-voltage V, the drive's amplitude, to keep it per volt)")
    file_names = list(raw.sensors)
    if sensor_names is not None:
        if len(sensor_names) != len(file_names):
            raise ValueError(f"{src}: --sensor-names gives {len(sensor_names)} names for the file's "
                             f"{len(file_names)} sensors ({', '.join(n or 'h' for n in file_names)})")
        names = [check_sensor_name(s, "--sensor-names gives") for s in sensor_names]
    else:
        names = [snake_name(n) for n in file_names]
        for n, orig in zip(names, file_names):
            check_sensor_name(n, f"{src}: the sensor {orig!r} becomes")
    if len(set(names)) != len(names):
        raise ValueError(f"{src}: two sensors are both named {next(n for n in names if names.count(n) > 1)}; "
                         "rename them by --sensor-names")
    pos = dict(sensor_positions or {})
    unplaced = [n for n in names if n not in pos]
    if unplaced:
        missing.append(f"the position of sensor{'s' if len(unplaced) > 1 else ''} {', '.join(unplaced)} "
                       f"(--sensor-positions {','.join(f'{n}=X' for n in unplaced)}, X along the beam [m])")
    if excitation_x is None:
        missing.append("where the force acts (--excitation-x X [m])")
    if F_N1 is None:
        missing.append("the bolt force held during the test (--fn1 F [N], 0 without an adaptive screw)")
    if missing:
        raise MissingInput(f"{src} does not say " + "; ".join(missing))
    f = np.asarray(raw.freq, float) * FREQUENCY_UNITS[f_unit]
    H = {n: c * _complex(src, k, raw.sensors[k], p_unit) for n, k in zip(names, file_names)}
    coh = {n: raw.sensors[k].parts["coh"] for n, k in zip(names, file_names) if "coh" in raw.sensors[k].parts}
    dropped = bool(len(f) and f[0] == 0.0)
    if dropped:
        f = f[1:]
        H = {n: h[1:] for n, h in H.items()}
        coh = {n: g[1:] for n, g in coh.items()}
    excitation = exc
    meta = {"format": FORMAT, "kind": "frf", "excitation_x_m": float(excitation_x),
            "sensor_positions_m": {n: float(pos[n]) for n in names}, "F_N1_N": float(F_N1),   # its own sensors
            "amplitude_n": None if amplitude is None else float(amplitude),
            "description": description or f"imported from {src.name}"}
    if exc == "drive_voltage" and force_scale is not None:
        H = {n: h / float(force_scale) for n, h in H.items()}
        excitation = "force"
        meta["description"] += f" (per volt divided by the force scale {force_scale:g} N/V)"
    if q != "accelerance":
        meta["quantity"] = q
    if excitation == "drive_voltage":
        meta["excitation"] = "drive_voltage"
        meta["drive_amplitude_v"] = float(drive_voltage)
        meta["amplitude_n"] = None
    test = FRFTest(stem, f, H, None, None, meta, coh or None)
    try:
        check_test(test)
    except ValueError as e:
        raise ValueError(f"{src}: {e}") from None
    row = {"source": str(src), "file": f"{stem}.csv", "sensors": dict(zip([k or "h" for k in file_names], names)),
           "lines": int(len(f)), "f_min_hz": float(f[0]) if len(f) else None,
           "f_max_hz": float(f[-1]) if len(f) else None, "quantity": q, "excitation": excitation,
           "unit": frf_unit(q, excitation), "dropped_dc_line": dropped}
    return test, row


def _write_folder(out: Path, tests: list[FRFTest], force: bool) -> None:
    """The tests into a temporary folder beside ``out``, read back, then renamed to ``out`` (an existing
    ``out``, with ``force``, moved aside first and removed once the new one is in place)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    aside = None
    try:
        for t in tests:
            write_frf_csv(tmp / f"{t.name}.csv", t)
            read_frf(tmp / f"{t.name}.csv")          # what diagnose and validate read
        tmp.chmod(0o755)
        if out.exists():
            aside = out.with_name(f".{out.name}.replaced-{os.getpid()}")
            os.replace(out, aside)
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        if aside is not None and not out.exists():
            os.replace(aside, out)
        raise
    if aside is not None:
        shutil.rmtree(aside) if aside.is_dir() else aside.unlink()
