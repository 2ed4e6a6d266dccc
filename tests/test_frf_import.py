"""FRF import (rt.log.frf_import, ``frictionrt import-frf``): the plant's own linear FRFs written as
analysers export them, one format each, imported and compared with the originals within each
format's precision; what a file does not say refused with its flag; nothing written on bad input."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from frictionrt.rt.log.frf_files import load_frf_folder, read_frf
from frictionrt.rt.log.frf_import import G_M_S2, MissingInput, import_frf, parse_unit, snake_name

POS = {"a_tip_meas": 0.765, "a_frf_meas": 0.45}      # the default structure's accelerometers [m]
KW = {"sensor_positions": POS, "excitation_x": 0.325, "fn1": 100.0}


@pytest.fixture(scope="module")
def plant_frf():
    """The stuck plant's accelerances [(m/s^2)/N] at F_N1 = 100 N on 150 lines 20-1500 Hz (uneven:
    an analyser's lines need not be, and the text formats must not assume it)."""
    from frictionrt.plant.linear_frf import point_accelerances
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.common.config import load
    from frictionrt.rt.discrepancy.rig.frf import sensor_points
    cfg = load(None, [])
    f = np.geomspace(20.0, 1500.0, 150)
    return f, point_accelerances(build_plant(cfg), sensor_points(cfg), 100.0, f)


def _rows(cols, fmt=repr, sep=",", dec="."):
    return "".join(sep.join(fmt(float(v)).replace(".", dec) for v in r) + "\n" for r in np.column_stack(cols))


def _re_im(f, H):
    return [f] + [c for h in H.values() for c in (h.real, h.imag)]


# --- one writer per format: (file name, writer(path, f, H), rtol of |dH|/|H|, rtol of f) ---------

def w_quoted(p, f, H):
    head = ",".join(['"Frequency [Hz]"'] + [f'"{s} {part} [(m/s^2)/N]"' for s in H for part in ("Real", "Imag")])
    p.write_text("# exported by an analyser\n" + head + "\n" + _rows(_re_im(f, H)))


def w_semicolon(p, f, H):
    head = ";".join(["freq_hz"] + [f"{s}_{part}" for s in H for part in ("re", "im")])
    p.write_text(f"Unit: (m/s^2)/N\n{head}\n" + _rows(_re_im(f, H), sep=";"))


def w_decimal_comma(p, f, H):
    head = ";".join(['"Frequenz [Hz]"'] + [f'"{s} re [m/s²/N]"; "{s} im [m/s²/N]"' for s in H])
    p.write_text(head + "\r\n" + _rows(_re_im(f, H), sep=";", dec=",").replace("\n", "\r\n"), encoding="cp1252")


def w_mag_phase(p, f, H):
    head = "\t".join(["Frequency (Hz)"] + [f"{s} Magnitude [g/N]\t{s} Phase [deg]" for s in H])
    cols = [f] + [c for h in H.values() for c in (np.abs(h) / G_M_S2, np.degrees(np.angle(h)))]
    p.write_text(head + "\n" + _rows(cols, fmt=lambda v: f"{v:.10g}", sep="\t"))


def w_rad_s(p, f, H):
    head = ",".join(["omega (rad/s)"] + [f"Re({s}) [(m/s^2)/N],Im({s}) [(m/s^2)/N]" for s in H])
    cols = _re_im(f, H)
    cols[0] = 2 * np.pi * f
    p.write_text(head + "\n" + _rows(cols))


def w_tab(p, f, H):
    head = "\t".join(["Frequency [Hz]"] + [f"{s} Mag [dB]\t{s} Phase [rad]" for s in H])
    cols = [f] + [c for h in H.values() for c in (20 * np.log10(np.abs(h)), np.angle(h))]
    p.write_text(head + "\n" + _rows(cols, fmt=lambda v: f"{v:.12g}", sep="\t"), encoding="utf-8")


def w_uff(p, f, H):
    import pyuff
    sets = [{"type": 58, "binary": 0, "id1": s, "id2": "analyser export", "func_type": 4, "rsp_node": j + 1,
             "rsp_dir": 3, "ref_node": 9, "ref_dir": 3, "abscissa_spacing": 0, "abscissa_spec_data_type": 18,
             "abscissa_axis_units_lab": "Hz", "ordinate_spec_data_type": 12, "orddenom_spec_data_type": 13,
             "ordinate_axis_units_lab": "m/s^2/N", "x": f, "data": h} for j, (s, h) in enumerate(H.items())]
    pyuff.UFF(str(p)).write_sets(sets, mode="overwrite")


def w_mat5(p, f, H):
    import scipy.io
    scipy.io.savemat(str(p), {"freq_hz": f, "H": np.column_stack(list(H.values())),
                              "sensors": np.array(list(H), dtype=object), "unit": "(m/s^2)/N"})


def w_mat73(p, f, H):
    h5py = pytest.importorskip("h5py")
    # as MATLAB's save -v7.3 writes: HDF5 with a 512-byte header, arrays column-major (transposed),
    # complex as a compound of real and imag, char as uint16 with MATLAB_class "char"
    with h5py.File(str(p), "w", userblock_size=512) as fh:
        fh["freq_hz"] = f[None, :]
        fh["freq_hz"].attrs["MATLAB_class"] = np.bytes_("double")
        for s, h in H.items():
            c = np.empty((1, len(h)), dtype=[("real", "<f8"), ("imag", "<f8")])
            c["real"], c["imag"] = h.real, h.imag
            fh[s] = c
            fh[s].attrs["MATLAB_class"] = np.bytes_("double")
        fh["unit"] = np.array([[ord(ch)] for ch in "(m/s^2)/N"], dtype=np.uint16)
        fh["unit"].attrs["MATLAB_class"] = np.bytes_("char")
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Dec  7 04:00:00 2026 HDF5 schema 1.00 ."
    with open(p, "r+b") as fh:   # 116 bytes of text, 8 of subsystem offset, version 0x0200, endian "IM"
        fh.write(text.ljust(116) + b"\0" * 8 + b"\x00\x02IM")


FORMATS = {  # writer, file name, rtol of H (|dH| / |H|), rtol of f[, what the file does not say]
    "quoted_header": (w_quoted, "fn100.csv", 0.0, 0.0),          # repr floats: exact
    "semicolon": (w_semicolon, "fn100.txt", 0.0, 0.0),
    "decimal_comma": (w_decimal_comma, "fn100.csv", 0.0, 0.0),   # repr with ',' for '.': exact
    "mag_phase_deg_g": (w_mag_phase, "fn100.txt", 2e-9, 5e-10),  # 10 digits: |H| 5e-10, phase 180e-10 deg
    "rad_s": (w_rad_s, "fn100.csv", 0.0, 4e-16),                # 2 pi f, then / 2 pi: 2 roundings
    "tab_db_rad": (w_tab, "fn100.tsv", 2e-11, 5e-12, {"unit": "(m/s^2)/N"}),  # 12 digits of dB and rad
    "uff": (w_uff, "fn100.uff", 1.5e-11, 5e-6),                 # pyuff ASCII: E20.11 ordinate, E13.5 abscissa
    "mat_v5": (w_mat5, "fn100.mat", 0.0, 0.0),
    "mat_v73": (w_mat73, "fn100.mat", 0.0, 0.0),
}


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_round_trip_per_format(tmp_path, plant_frf, fmt):
    write, name, rtol_h, rtol_f, *said = FORMATS[fmt]
    f, H = plant_frf
    src = tmp_path / name
    write(src, f, H)
    res = import_frf(src, tmp_path / "out", **KW, **(said[0] if said else {}))
    (t,) = load_frf_folder(tmp_path / "out")
    assert t.quantity == "accelerance" and t.excitation == "force" and t.meta["sensor_positions_m"] == POS
    np.testing.assert_allclose(t.freq_hz, f, rtol=rtol_f, atol=0)
    assert sorted(t.H) == sorted(H)             # in the file's order; HDF5 lists by name
    for s, h in H.items():
        err = np.abs(t.H[s] - h) / np.abs(h)
        assert err.max() <= rtol_h, (s, err.max())
    assert res.to_dict()["tests"][0]["lines"] == len(f) and res.files == [tmp_path / "out" / "fn100.csv"]


def test_cli_writes_what_validate_accepts(tmp_path, plant_frf, capsys):
    from frictionrt.rt.cli.app import main
    f, H = plant_frf
    w_decimal_comma(tmp_path / "a.csv", f, H)
    w_uff(tmp_path / "b.uff", f, H)
    out = tmp_path / "lab"
    code = main(["import-frf", str(tmp_path / "a.csv"), str(tmp_path / "b.uff"), "-o", str(out), "--fn1", "40,300",
                 "--excitation-x", "0.325", "--sensor-positions", "a_tip_meas=0.765,a_frf_meas=0.45"])
    text = capsys.readouterr().out
    assert code == 0 and "2 FRF files in" in text and "a_tip_meas" in text
    assert [t.F_N1 for t in load_frf_folder(out)] == [40.0, 300.0]
    assert main(["validate", str(out)]) == 0
    assert capsys.readouterr().out.strip() == f"{out}: valid (2 FRF files)"
    assert main(["validate", str(out / "a.csv"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["valid"] is True


def test_truncated_uff_names_the_line(tmp_path, plant_frf):
    f, H = plant_frf
    w_uff(tmp_path / "full.uff", f, H)
    lines = (tmp_path / "full.uff").read_text().splitlines(keepends=True)
    for cut in (40, len(lines) - 3):   # inside the first data set; inside the last (pyuff would read only the first)
        (tmp_path / "cut.uff").write_text("".join(lines[:cut]))
        with pytest.raises(ValueError, match=rf"cut.uff: truncated after line {cut}\b"):
            import_frf(tmp_path / "cut.uff", tmp_path / "out", **KW)
        assert not (tmp_path / "out").exists()


def test_truncated_frf_file_in_the_reader(tmp_path, plant_frf):
    """The FRF-file reader itself (diagnose's) says where a UFF was cut, not "no data set 58"."""
    f, H = plant_frf
    from frictionrt.rt.log.frf_files import FORMAT, FRFTest, write_frf_uff
    meta = {"format": FORMAT, "kind": "frf", "excitation_x_m": 0.325, "sensor_positions_m": POS, "F_N1_N": 100.0,
            "amplitude_n": 1.0, "description": "x"}
    write_frf_uff(tmp_path / "t.uff", FRFTest("t", f, H, None, None, meta))
    lines = (tmp_path / "t.uff").read_text().splitlines(keepends=True)
    (tmp_path / "t.uff").write_text("".join(lines[:30]))
    with pytest.raises(ValueError, match=r"t.uff: truncated after line 30\b"):
        read_frf(tmp_path / "t.uff")


def _write(tmp_path, writer, name, f, H) -> Path:
    writer(tmp_path / name, f, H)
    return tmp_path / name


def test_units_and_drive_voltage(tmp_path, plant_frf):
    f, H = plant_frf
    src = _write(tmp_path, w_quoted, "v.csv", f, H)
    src.write_text(src.read_text().replace("(m/s^2)/N", "(mm/s)/V"))
    with pytest.raises(MissingInput, match=r"per volt: --force-scale N_PER_V .* or --drive-voltage V"):
        import_frf(src, tmp_path / "o", **KW)
    import_frf(src, tmp_path / "o", force_scale=0.5, **KW)
    (t,) = load_frf_folder(tmp_path / "o")
    assert t.quantity == "mobility" and t.excitation == "force"
    np.testing.assert_allclose(t.H["a_tip_meas"], H["a_tip_meas"] * 1e-3 / 0.5, rtol=1e-15)
    import_frf(src, tmp_path / "o2", drive_voltage=2.0, **KW)
    (t,) = load_frf_folder(tmp_path / "o2")
    assert t.excitation == "drive_voltage" and t.meta["drive_amplitude_v"] == 2.0 and t.unit == "(m/s)/V"
    assert parse_unit("m/s²/N") == ("accelerance", "force", 1.0) and parse_unit("µm/N")[2] == 1e-6
    assert snake_name("Acc 1 +Z") == "acc_1_z" and snake_name("1") == "s_1"


def test_dc_line_dropped(tmp_path, plant_frf):
    f, H = plant_frf
    src = _write(tmp_path, w_semicolon, "d.txt", f, H)
    lines = src.read_text().splitlines(keepends=True)
    src.write_text("".join(lines[:2]) + "0.0" + ";0.0" * 4 + "\n" + "".join(lines[2:]))
    res = import_frf(src, tmp_path / "o", **KW)
    assert res.tests[0]["dropped_dc_line"] and res.tests[0]["lines"] == len(f)


# --- what the file does not say, and bad input: one line, nothing written ------------------------

def _plain(tmp_path, f, H, head="f,a1 re,a1 im") -> Path:
    p = tmp_path / "plain.csv"
    h = H["a_tip_meas"]
    p.write_text(head + "\n" + _rows([f, h.real, h.imag]))
    return p


@pytest.mark.parametrize("kw, missing", [
    ({}, r"the frequency's unit \(--frequency-unit hz or rad/s\); the FRF's unit \(--unit.*; the position of sensor "
         r"a1 \(--sensor-positions a1=X.*; where the force acts \(--excitation-x X \[m\]\); the bolt force .*--fn1"),
    ({"frequency_unit": "hz", "quantity": "accelerance", "excitation_x": 0.3, "fn1": 0},
     r"does not say the position of sensor a1 \(--sensor-positions a1=X"),
])
def test_missing_input_named_with_its_flag(tmp_path, plant_frf, kw, missing):
    p = _plain(tmp_path, *plant_frf)
    with pytest.raises(MissingInput, match=missing) as exc:
        import_frf(p, tmp_path / "out", **kw)
    assert "\n" not in str(exc.value)
    assert not (tmp_path / "out").exists() and sorted(x.name for x in tmp_path.iterdir()) == ["plain.csv"]


@pytest.mark.parametrize("change, kw, msg", [
    (None, {"frequency_unit": "rad/s"}, r"the file says the frequency in hz, --frequency-unit gives rad/s"),
    (None, {"unit": "g/N"}, r"the file says the FRF is in \(m/s\^2\)/N, the flags give g/N"),
    (("Imag", "Phase"), {}, r"the phase's unit \(--phase-unit deg or rad\)"),
    (("Imag", "Volts"), {}, r"column '\"?a_tip_meas Volts .* is neither the frequency nor a part"),
    (("2.0", "2.x"), {}, r"line \d+ has|not a row of numbers|is not"),
    (("Frequency [Hz]", "Time [s]"), {}, r"the first column .Time \[s\]. is not a frequency"),
])
def test_bad_input_refused(tmp_path, plant_frf, change, kw, msg):
    f, H = plant_frf
    src = _write(tmp_path, w_quoted, "b.csv", f, H)
    if change:
        src.write_text(src.read_text().replace(*change))
    with pytest.raises(ValueError, match=msg):
        import_frf(src, tmp_path / "out", **(KW | kw))
    assert not (tmp_path / "out").exists() and [x.name for x in tmp_path.iterdir()] == ["b.csv"]


def test_bad_second_source_keeps_the_old_folder(tmp_path, plant_frf, capsys):
    from frictionrt.rt.cli.app import main
    f, H = plant_frf
    good = _write(tmp_path, w_quoted, "g.csv", f, H)
    import_frf(good, tmp_path / "out", **KW)
    before = {p.name: p.read_bytes() for p in (tmp_path / "out").iterdir()}
    bad = tmp_path / "h.csv"
    bad.write_text(good.read_text().replace("[Hz]", "[kHz]"))
    code = main(["import-frf", str(good), str(bad), "-o", str(tmp_path / "out"), "--force", "--fn1", "100",
                 "--excitation-x", "0.3", "--sensor-positions", "a_tip_meas=0.765,a_frf_meas=0.45"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "h.csv does not say the frequency's unit" in err
    assert {p.name: p.read_bytes() for p in (tmp_path / "out").iterdir()} == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.csv", "h.csv", "out"]


def test_mat73_without_h5py_says_so(tmp_path, plant_frf, monkeypatch):
    pytest.importorskip("h5py")
    f, H = plant_frf
    src = _write(tmp_path, w_mat73, "m.mat", f, H)
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(ValueError, match=r"m.mat: a MATLAB v7.3 \(HDF5\) file needs h5py"):
        import_frf(src, tmp_path / "out", **KW)



# --- the docs' worked example (docs/discrepancy.md, "Your own measured FRFs") runs as written -------

def _doc_blocks() -> list[tuple[str, str]]:
    text = (Path(__file__).resolve().parents[1] / "docs" / "discrepancy.md").read_text()
    sec = text[text.index("## Your own measured FRFs"):]
    sec = sec[:sec.index("\n## ", 5)]
    import re
    return re.findall(r"```(\w+)\n(.*?)```", sec, re.S)


def test_docs_worked_example(tmp_path, monkeypatch, capsys):
    import shlex

    from frictionrt.rt.cli.app import main
    monkeypatch.chdir(tmp_path)
    blocks = _doc_blocks()
    assert [k for k, _ in blocks] == ["python", "console", "console", "python", "text"]
    exec(blocks[0][1], {})
    for kind, body in blocks[1:3]:
        lines = body.splitlines()
        i = 0
        while i < len(lines):
            cmd = shlex.split(lines[i].removeprefix("$ "))
            want = []
            i += 1
            while i < len(lines) and not lines[i].startswith("$ "):
                want.append(lines[i])
                i += 1
            code = main(cmd[1:])
            out = capsys.readouterr()
            got = (out.out + out.err).rstrip("\n").splitlines()
            assert got == want, (cmd, got)
            assert code == (2 if "error" in "".join(want) else 0)
    exec(blocks[3][1], {})
    assert capsys.readouterr().out.splitlines() == blocks[4][1].splitlines()
    (t,) = load_frf_folder("logs/lab_frf")
    assert t.meta["sensor_positions_m"] == {"acc_tip": 0.765, "acc_mid": 0.45}


def test_validate_names_the_problem_of_an_frf_folder(tmp_path, plant_frf, capsys):
    from frictionrt.rt.cli.app import main
    f, H = plant_frf
    import_frf(_write(tmp_path, w_quoted, "q.csv", f, H), tmp_path / "out", **KW)
    side = tmp_path / "out" / "q.json"
    side.write_text(side.read_text().replace('"F_N1_N": 100.0', '"F_N1_N": -1.0'))
    assert main(["validate", str(tmp_path / "out")]) == 1
    out = capsys.readouterr().out
    assert out.startswith(f"{tmp_path / 'out'}: INVALID, 1 problem:") and "F_N1_N is -1.0" in out, out
    assert main(["validate", str(tmp_path / "nothing")]) == 2
