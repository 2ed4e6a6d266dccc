"""FRF files (rt.log.frf_files): round trips of CSV (bit-exact) and UFF (to its ASCII precision), and
the readers' messages on bad files (file named, problem, fix)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from frictionrt.rt.log.frf_files import (
    FORMAT,
    FRFTest,
    load_frf_folder,
    read_frf,
    sidecar_path,
    write_frf_csv,
    write_frf_uff,
)


def _test(n: int = 400, amps: bool = True) -> FRFTest:
    rng = np.random.default_rng(3)
    f = 4.0 + 0.25 * np.arange(n)
    # magnitudes over 12 decades, like accelerances from an antiresonance floor to a resonance
    H = {s: 10.0 ** rng.uniform(-6, 6, n) * np.exp(2j * np.pi * rng.uniform(size=n))
         for s in ("a_frf_meas", "a_tip_meas")}
    meta = {"format": FORMAT, "kind": "stepsine", "excitation_x_m": 0.3,
            "sensor_positions_m": {"a_frf_meas": 0.45, "a_tip_meas": 0.765}, "F_N1_N": 100.0 + 1 / 3,
            "amplitude_n": 5.0, "description": "step-sine at 5 N"}
    F_amp = 5.0 + 0.1 * rng.standard_normal(n) if amps else None
    drive = 5.0 * (1.0 + rng.uniform(size=n) / 7) if amps else None
    return FRFTest("t", f, H, F_amp, drive, meta)


def test_csv_round_trip_is_bit_exact(tmp_path):
    t = _test()
    write_frf_csv(tmp_path / "lvl1.csv", t)
    r = read_frf(tmp_path / "lvl1.csv")
    assert r.name == "lvl1" and r.meta == t.meta and r.F_N1 == t.meta["F_N1_N"]
    assert np.array_equal(r.freq_hz, t.freq_hz)
    for s in t.H:
        assert np.array_equal(r.H[s].view(float), t.H[s].view(float))
    assert np.array_equal(r.F_amp_N, t.F_amp_N) and np.array_equal(r.drive_amp, t.drive_amp)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lvl1.csv", "lvl1.json"]   # no temporary left


def test_uff_round_trip_to_its_precision(tmp_path):
    """ASCII UFF 58: frequency E13.5 (the 0.25 Hz grid has <= 6 digits: exact), ordinate E20.11:
    each part within 5e-12 of itself, so |dH| / |H| <= 5e-12 sqrt(2) < 1e-11."""
    t = _test()
    write_frf_uff(tmp_path / "lvl2.uff", t)
    r = read_frf(tmp_path / "lvl2.uff")
    assert np.array_equal(r.freq_hz, t.freq_hz)
    for s in t.H:
        assert np.max(np.abs(r.H[s] - t.H[s]) / np.abs(t.H[s])) < 1e-11
        assert not np.array_equal(r.H[s], t.H[s])          # it is rounded: the tolerance is needed
    assert np.max(np.abs(r.F_amp_N / t.F_amp_N - 1)) < 1e-11
    assert np.max(np.abs(r.drive_amp / t.drive_amp - 1)) < 1e-11
    assert r.meta == t.meta


def test_uff_without_amplitudes_and_uneven_lines(tmp_path):
    t = _test(n=60, amps=False)
    f = np.sort(np.random.default_rng(1).uniform(1.0, 2000.0, len(t.freq_hz)))
    t = FRFTest("t", f, {"a_frf_meas": t.H["a_frf_meas"]}, None, None, t.meta)
    write_frf_uff(tmp_path / "u.unv", t)
    r = read_frf(tmp_path / "u.unv")
    assert list(r.H) == ["a_frf_meas"] and r.F_amp_N is None and r.drive_amp is None
    assert np.max(np.abs(r.freq_hz / f - 1)) <= 5e-6           # 6 significant digits
    with pytest.raises(ValueError, match="closer than the 6 significant digits"):
        write_frf_uff(tmp_path / "v.uff", FRFTest("t", np.array([1000.0, 1000.001]),
                                                   {"a_frf_meas": np.ones(2, complex)}, None, None, t.meta))
    assert not (tmp_path / "v.uff").exists() and not (tmp_path / "v.json").exists()


def test_load_folder(tmp_path):
    t = _test(n=20)
    write_frf_csv(tmp_path / "a.csv", t)
    write_frf_uff(tmp_path / "b.uff", t)
    (tmp_path / "notes.txt").write_text("ignored")
    assert [x.name for x in load_frf_folder(tmp_path)] == ["a", "b"]
    write_frf_uff(tmp_path / "a.uff", t)
    with pytest.raises(ValueError, match="two data files named a.* share the sidecar a.json"):
        load_frf_folder(tmp_path)
    with pytest.raises(ValueError, match="notes.txt: not a folder"):
        load_frf_folder(tmp_path / "notes.txt")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no FRF files"):
        load_frf_folder(tmp_path / "empty")


def _csv(tmp_path: Path, text: str, meta: dict | None = None) -> Path:
    p = tmp_path / "x.csv"
    p.write_text(text)
    sidecar_path(p).write_text(json.dumps(meta if meta is not None else _test().meta))
    return p


GOOD_HEADER = "freq_hz,a_frf_meas_re,a_frf_meas_im\n"
CSV_CASES = {
    "empty": ("", "empty file"),
    "bad header": ("frequency,a_frf_meas_re,a_frf_meas_im\n1,2,3\n", "not freq_hz"),
    "unknown column": ("freq_hz,a_frf_meas_re,a_frf_meas_im,coherence\n1,2,3,4\n2,2,3,4\n",
                       "unknown header column 'coherence'"),
    "complex part missing": ("freq_hz,a_frf_meas_re\n1,2\n2,3\n", "column a_frf_meas_im missing"),
    "duplicate": ("freq_hz,a_frf_meas_re,a_frf_meas_im,a_frf_meas_re\n1,2,3,4\n", "appears twice"),
    "field count": (GOOD_HEADER + "1,2,3\n2,2\n", "line 3 has 2 fields, the header 3"),
    "not a number": (GOOD_HEADER + "1,2,3\n2,x,3\n", "line 3, column a_frf_meas_re: 'x' is not a number"),
    "NaN": (GOOD_HEADER + "1,2,3\n2,nan,3\n", "a_frf_meas is NaN or inf at line 2"),
    "non-increasing": (GOOD_HEADER + "1,2,3\n3,2,3\n2,2,3\n", "not increasing at line 3: 2.0 Hz after 3.0 Hz"),
    "zero frequency": (GOOD_HEADER + "0,2,3\n3,2,3\n", "frequencies must be > 0"),
    "one line": (GOOD_HEADER + "1,2,3\n", "at least 2"),
    "NaN frequency": (GOOD_HEADER + "1,2,3\nnan,2,3\n", "frequency line 2 is not finite"),
    "negative amplitude": ("freq_hz,F_amp_N,a_frf_meas_re,a_frf_meas_im\n1,1,2,3\n2,-1,2,3\n",
                           "F_amp_N <= 0 at line 2"),
}


@pytest.mark.parametrize("case", CSV_CASES)
def test_csv_errors_name_file_problem(tmp_path, case):
    text, msg = CSV_CASES[case]
    p = _csv(tmp_path, text)
    with pytest.raises(ValueError) as exc:
        read_frf(p)
    assert str(exc.value).startswith(f"{p}: ") and msg in str(exc.value)


SIDE_CASES = {
    "missing key": (lambda m: m.pop("F_N1_N"), "F_N1_N missing"),
    "format": (lambda m: m.update(format="other/2"), "format is 'other/2'"),
    "kind": (lambda m: m.update(kind="impulse"), "kind is 'impulse'; give one of stepsine, frf"),
    "F_N1 NaN": (lambda m: m.update(F_N1_N=float("nan")), "F_N1_N is nan, not a finite number"),
    "F_N1 string": (lambda m: m.update(F_N1_N="100"), "F_N1_N is '100'"),
    "F_N1 negative": (lambda m: m.update(F_N1_N=-1.0), "F_N1_N is -1.0; it must be >= 0 (0: a structure without"),
    "bad sensor name": (lambda m: m["sensor_positions_m"].update({"Accel-X": 0.1}),
                        "'Accel-X', which is not a valid sensor name: name sensors in lowercase snake_case"),
    "reserved sensor name": (lambda m: m["sensor_positions_m"].update(stamp=0.1), "'stamp', which is not a valid"),
    "quantity": (lambda m: m.update(quantity="inertance"),
                 "quantity is 'inertance'; give one of accelerance, mobility, receptance"),
    "excitation": (lambda m: m.update(excitation="current"), "excitation is 'current'; give one of force, drive_voltage"),
    "sensor_beams type": (lambda m: m.update(sensor_beams=["main"]), "sensor_beams is \"['main']\"; give an object"),
    "sensor_beams unplaced": (lambda m: m.update(sensor_beams={"v_x": "main"}), "sensor_beams names 'v_x', which has no"),
    "sensor_beams value": (lambda m: m.update(sensor_beams={"a_tip_meas": 3}), "sensor_beams.a_tip_meas is '3'"),
    "sensor not placed": (lambda m: m["sensor_positions_m"].pop("a_frf_meas"),
                          "sensor a_frf_meas has no position in the sidecar"),
}


@pytest.mark.parametrize("case", SIDE_CASES)
def test_sidecar_errors(tmp_path, case):
    edit, msg = SIDE_CASES[case]
    meta = json.loads(json.dumps(_test().meta))
    edit(meta)
    p = _csv(tmp_path, GOOD_HEADER + "1,2,3\n2,2,3\n", meta)
    with pytest.raises(ValueError) as exc:
        read_frf(p)
    assert msg in str(exc.value)
    assert str(exc.value).startswith((f"{p}: ", f"{sidecar_path(p)}: "))


def test_missing_and_broken_sidecar(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text(GOOD_HEADER + "1,2,3\n2,2,3\n")
    with pytest.raises(ValueError, match=r"x.csv: no sidecar x.json beside it; write one"):
        read_frf(p)
    sidecar_path(p).write_text("{")
    with pytest.raises(ValueError, match=r"x.json: not valid JSON"):
        read_frf(p)


def _uff_with(tmp_path, **changes) -> Path:
    import pyuff
    p = tmp_path / "x.uff"
    t = _test(n=10, amps=False)
    write_frf_uff(p, t)
    sets = pyuff.UFF(str(p)).read_sets()
    sets[0].update(changes)
    p.unlink()
    pyuff.UFF(str(p)).write_sets(sets, mode="overwrite")
    return p


@pytest.mark.parametrize("changes, msg", [
    ({"func_type": 1}, "function type 1"),
    ({"id1": "Accel 7"}, "'Accel 7', which is not a valid sensor name"),
    ({"id1": "accel_7"}, "sensor accel_7 has no position in the sidecar"),
    ({"ordinate_spec_data_type": 11}, "ordinate data characteristic 11 (mobility), but the sidecar says quantity "
                                      "'accelerance'"),
    ({"data": np.abs(np.ones(10))}, "real ordinate"),
    ({"abscissa_spec_data_type": 17}, "abscissa data type 17"),
    ({"id1": "a_tip_meas"}, "two data sets for a_tip_meas"),
])
def test_uff_errors(tmp_path, changes, msg):
    p = _uff_with(tmp_path, **changes)
    with pytest.raises(ValueError) as exc:
        read_frf(p)
    assert str(exc.value).startswith(f"{p}: ") and msg in str(exc.value)


def test_uff_nan(tmp_path):
    p = _uff_with(tmp_path)
    lines = p.read_text().splitlines(True)
    i = next(j for j, line in enumerate(lines) if line.startswith("  4.50000e+00"))
    lines[i] = lines[i][:13] + f"{'nan':>20}" + lines[i][33:]
    p.write_text("".join(lines))
    with pytest.raises(ValueError, match=r"x.uff: a_\w+_meas is NaN or inf at line 3"):
        read_frf(p)


def test_uff_garbage(tmp_path):
    p = tmp_path / "g.uff"
    p.write_bytes(b"\x00\xff garbage\n    -1\n    58\nnonsense\n    -1\n")
    sidecar_path(p).write_text(json.dumps(_test().meta))
    with pytest.raises(ValueError, match=r"g.uff: (not a readable universal file|.*data set)"):
        read_frf(p)
    p.write_text("hello\n")
    with pytest.raises(ValueError, match=r"g.uff: no data set 58"):
        read_frf(p)



@pytest.mark.parametrize("quantity, spec", [("receptance", 8), ("mobility", 11), ("accelerance", 12)])
@pytest.mark.parametrize("excitation, denom", [("force", 13), ("drive_voltage", 0)])
def test_quantities_and_sensor_names_round_trip(tmp_path, quantity, spec, excitation, denom):
    """Issue 18: a receptance, mobility or accelerance per newton or per volt, of sensors of any
    valid name: CSV bit-exact, UFF to its precision, the UFF data sets stating the quantity in the
    ordinate numerator (8, 11, 12) and the excitation in the denominator (13 force, 0 a voltage)."""
    import pyuff
    t = _test(n=50, amps=False)
    H = {"v_tip_laser": t.H["a_tip_meas"], "a_frf_meas": t.H["a_frf_meas"]}
    meta = t.meta | {"sensor_positions_m": {"v_tip_laser": 0.765, "a_frf_meas": 0.45}, "quantity": quantity,
                     "excitation": excitation, "sensor_beams": {"v_tip_laser": "main"}}
    t = FRFTest("t", t.freq_hz, H, None, None, meta)
    assert t.unit == {"receptance": "m", "mobility": "(m/s)", "accelerance": "(m/s^2)"}[quantity] + (
        "/N" if excitation == "force" else "/V")
    write_frf_csv(tmp_path / "q.csv", t)
    write_frf_uff(tmp_path / "q.uff", t)
    c, u = read_frf(tmp_path / "q.csv"), read_frf(tmp_path / "q.uff")
    assert c.meta == u.meta == meta and c.quantity == quantity and u.excitation == excitation
    for s in H:
        assert np.array_equal(c.H[s], H[s]) and np.max(np.abs(u.H[s] / H[s] - 1)) < 1e-11
    sets = pyuff.UFF(str(tmp_path / "q.uff")).read_sets()
    assert [(d["id1"], d["ordinate_spec_data_type"], d["orddenom_spec_data_type"], d["rsp_node"]) for d in sets] == [
        ("v_tip_laser", spec, denom, 3), ("a_frf_meas", spec, denom, 2)]


def test_from_accelerance_is_the_time_integral():
    """H_v = H_a / (i w), H_x = H_a / (i w)^2: a mass m (H_a = 1/m) has the receptance -1/(m w^2)."""
    from frictionrt.rt.log.frf_files import from_accelerance
    f = np.array([1.0, 10.0, 100.0])
    w = 2 * np.pi * f
    Ha = np.full(3, 0.5 + 0j)
    assert np.allclose(from_accelerance(Ha, f, "receptance"), -0.5 / w ** 2, rtol=1e-15)
    assert np.allclose(from_accelerance(Ha, f, "mobility"), 0.5 / (1j * w), rtol=1e-15)
    assert from_accelerance(Ha, f, "accelerance") is Ha


def test_uff_excitation_disagreeing_with_sidecar(tmp_path):
    """A data set stating an excitation force (13) in a file whose sidecar says drive_voltage."""
    p = _uff_with(tmp_path)
    sidecar_path(p).write_text(json.dumps(_test().meta | {"excitation": "drive_voltage"}))
    with pytest.raises(ValueError, match="ordinate denominator 13 .excitation force., but the sidecar says excitation "
                                         "'drive_voltage'"):
        read_frf(p)
