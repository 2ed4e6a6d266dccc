"""The discrepancy workflow on measured FRF files (issue 7): ``rig --frf-files`` writes linear
(stuck-contact) FRF tests of the true structure with a hidden effect, ``diagnose`` names it, fits
its strength and closes the FRF gap, on the benchmark and on another structure (the lap joint of
configs/lap_joint.toml). Seed 5 was not used while developing (seeds 3 and 11 were)."""
import json
import math
import re
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from frictionrt.plant.linear_frf import continuous_accelerance, stuck_model
from frictionrt.plant.model import build_plant
from frictionrt.rt.cli import main
from frictionrt.rt.common.config import Config, load, with_sets
import frictionrt.rt.discrepancy.diagnose.frf as frf_module
from frictionrt.rt.discrepancy.diagnose.frf import diagnose_frf, prepare, residuals
from frictionrt.rt.discrepancy.effects import get, implemented
from frictionrt.rt.log.frf_files import load_frf_folder
from frictionrt.plant.linear_frf import modal_accelerance
from frictionrt.rt.discrepancy.chain import scaled
from frictionrt.rt.discrepancy.rig import scatter_sets
from frictionrt.rt.discrepancy.rig.frf import FREQ_HZ, make_frf_campaign

CONFIGS = Path(__file__).resolve().parents[1] / "configs"

SEED = 5
LAP_JOINT = Path(__file__).resolve().parents[1] / "configs" / "lap_joint.toml"
STRUCTURAL = [e for e in implemented() if e.visible_in_frf_files()]


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    cache = {}

    def get_(effect: str):
        if effect not in cache:
            cache[effect] = make_frf_campaign(tmp_path_factory.mktemp(effect) / "c", effect, seed=SEED)[0].parent
        return cache[effect]
    return get_


def test_modal_accelerance_is_the_linear_frf():
    """frictionrt.plant.linear_frf.modal_accelerance (one eigen decomposition) against plant.linear_frf's per-line solve, at a
    low and a high F_N1 (other pairs closed), both accelerometer points."""
    model = build_plant(with_sets(Config(), []))
    f = FREQ_HZ[::97]
    for F_N1 in (40.0, 300.0):
        for point in ("frf", "tip"):
            lin = stuck_model(model, point, F_N1)
            H, ref = modal_accelerance(lin, f), continuous_accelerance(lin, f)
            assert np.max(np.abs(H / ref - 1.0)) < 1e-7


@pytest.mark.parametrize("effect", STRUCTURAL, ids=lambda e: e.name)
def test_hidden_effect_is_named_from_frf_files(campaigns, effect):
    res = diagnose_frf(campaigns(effect.name))
    assert res["named_effect"] == effect.name, res["ranking"]
    assert res["ranking"][0]["effect"] == effect.name and res["ranking"][0]["delta_bic"] > 10.0
    fitted = res["fitted_parameters"][effect.name]
    assert abs(fitted / effect.parameter.default - 1.0) < 0.30, fitted
    before, after = res["gap_before"]["structure_frf_db"], res["gap_after"]["structure_frf_db"]
    assert before >= 3.0 * after, (before, after)
    # the budget: the effect explains a real share (seed 3, moving_mass: 23 %), nothing dominant remains
    b = res["gap_budget"]
    assert b["effect_share"] > 0.1 and abs(b["remainder_share"]) < 0.01 and not b["remainder_dominates"], b


def test_true_parameters_fit_at_noise_level(campaigns):
    """(ln|H_meas| - ln|H_model|) / sigma_k is O(1) at the campaign's true parameters (the noise
    estimate from the data is right: rms 0.6, sigma_k includes the 1 % model floor) and far
    outside it for the nominal model (scatter alone)."""
    nominal = with_sets(Config(), [])
    true = scaled(nominal, scatter_sets(np.random.default_rng(SEED)))   # make_frf_campaign's first draws
    data = prepare(load_frf_folder(campaigns("none")), nominal)
    assert np.allclose([d.F_N1 for d in data], [40, 100, 300], rtol=0.04)   # held within 1 % rms
    assert all(d.sel[s].sum() > 6000 for d in data for s in d.sel)     # of 6385 lines
    rms = {s: float(np.sqrt(np.mean(r ** 2))) for s, r in residuals(true, data)[0].items()}
    rms_nominal = {s: float(np.sqrt(np.mean(r ** 2))) for s, r in residuals(nominal, data)[0].items()}
    assert all(v < 1.0 for v in rms.values()), rms
    assert all(v > 5.0 for v in rms_nominal.values()), rms_nominal


def test_no_effect_names_nothing_through_the_cli(campaigns, tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["diagnose", str(campaigns("none")), "--json", "--out", str(out)]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["named_effect"] is None, res["ranking"]
    assert res["ranking"][0]["delta_bic"] <= 10.0 and res["input"] == "frf_files"
    assert set(res["fitted_parameters"]) == {"E", "k_t", "modal_damping"}
    b = res["gap_budget"]   # the model form is the truth's: calibration explains all but the noise
    assert b["calibration_share"] > 0.99 and b["rms_final"] < 1.0 and not b["remainder_dominates"], b
    assert json.loads((out / "diagnose.json").read_text()) == res
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["diagnose.json", "model.toml", "report.md", "diagnosis.rrd"] + [f"frf_frf_0{j}.png" for j in (1, 2, 3)])
    fitted = load(out / "model.toml")          # the calibrated model: E within its scatter draw
    assert fitted.plant.beams[0].E == pytest.approx(with_sets(Config(), []).plant.beams[0].E
                                                    * res["fitted_parameters"]["E"], rel=1e-5)


def test_files_do_not_reveal_the_effect(campaigns):
    clean, hidden = campaigns("none"), campaigns("clamp_compliance")
    names = sorted(p.name for p in clean.iterdir())
    assert names == sorted(p.name for p in hidden.iterdir()) == [
        "frf_01.csv", "frf_01.json", "frf_02.json", "frf_02.uff", "frf_03.csv", "frf_03.json"]
    for n in names:
        if n.endswith(".json"):    # same seed: the same held F_N1, the same sidecar
            assert (clean / n).read_bytes() == (hidden / n).read_bytes()
        else:
            assert (clean / n).read_bytes() != (hidden / n).read_bytes()
        text = (hidden / n).read_bytes().lower()
        assert b"clamp" not in text and b"compliance" not in text and b"effect" not in text


def test_another_structure_from_toml(tmp_path, capsys):
    """The lap joint (two beams, the damper's screws in a lap joint, other points): rig and
    diagnose with --config; the benchmark model on its files is refused (positions differ)."""
    d = tmp_path / "lap"
    assert main(["--config", str(LAP_JOINT), "rig", "--effect", "moving_mass", "--frf-files", "--seed", str(SEED),
                 "-o", str(d)]) == 0
    capsys.readouterr()
    assert main(["--config", str(LAP_JOINT), "diagnose", str(d), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["named_effect"] == "moving_mass", res["ranking"]
    assert abs(res["fitted_parameters"]["moving_mass"] / get("moving_mass").parameter.default - 1) < 0.30
    assert res["gap_before"]["structure_frf_db"] >= 3.0 * res["gap_after"]["structure_frf_db"]
    assert main(["diagnose", str(d)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "excitation at x = 0.2 m, but the model's point 'exc' is at 0.325 m" in err[0]


def test_effects_linear_frfs_cannot_show_are_refused_and_not_tried(tmp_path, capsys):
    """stribeck and micro_slip leave the stuck structure alone, the actuator effects have no place in
    an FRF: rig --frf-files refuses them (exit 2, one line, no folder) and diagnose lists them under
    not_tried rather than fitting a parameter the linear model cannot feel."""
    for name in ("stribeck", "micro_slip", "current_limit"):
        assert not get(name).visible_in_frf_files()
        assert main(["rig", "--effect", name, "--frf-files", "-o", str(tmp_path / name)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "FRF files cannot show it" in err[0] and not (tmp_path / name).exists()
    assert {e.name for e in STRUCTURAL} == {"accelerometer_mass", "clamp_compliance", "moving_mass"}


# --- issue 18: measurements as labs have them, calibration from far away ---------------------------
# one-level folders (F_N1 = 100 N) keep these fast: ~3 s per diagnosis instead of ~9 s

ONE_LEVEL = (100.0,)
ACC, CLAMP = ("accelerometer_mass",), ("clamp_compliance",)     # trying_only: the effect a test asserts on
THREE_SENSORS = {"v_tip_laser": ("main", 0.765), "v_mid": ("main", 0.3333), "v_root": ("main", 0.1234)}


@pytest.fixture(scope="module")
def one_level(tmp_path_factory, shared_results):
    """(folder, diagnose_frf result) of a one-level folder per (effect, file kind, nominal), computed
    once per run for both xdist workers (conftest's ``shared_results``): the reference diagnoses (no
    effect and clamp_compliance's drive-voltage folder, each asked for by 3-7 tests) were computed on
    each worker that ran one of their tests. Keyed on the nominal's repr (the folder and the diagnosis
    follow from the effect, the kind, the seed and the nominal)."""
    kinds = {"accelerance": {}, "receptance": {"quantity": "receptance"},
             "mobility_sensors": {"quantity": "mobility", "sensors": THREE_SENSORS},
             "drive_voltage": {"force_scale_N_per_V": 0.37}}

    def get_(effect: str, kind: str, nominal: Config | None = None, only: tuple[str, ...] | None = None):
        def compute():
            d = tmp_path_factory.mktemp(f"{effect}_{kind}") / "c"
            make_frf_campaign(d, effect, seed=SEED, levels_n=ONE_LEVEL, **kinds[kind])
            with trying_only(only):
                return d, diagnose_frf(d, nominal)
        return shared_results(("one_level", effect, kind, SEED, None if nominal is None else repr(nominal), only),
                              compute)
    return get_


@contextmanager
def trying_only(names: tuple[str, ...] | None):
    """``diagnose_frf`` with only the candidates ``names`` fitted (None: all; (): calibration alone).
    The candidates' fits are ~90 % of a one-level diagnosis (profiled: calibration 3 s, the three
    candidates 20-30 s each); tests that assert on the calibration or on one effect's fit take only
    what they assert on. The ranking among all candidates is test_hidden_effect_is_named_from_frf_files's
    and test_no_effect_names_nothing_through_the_cli's."""
    if names is None:
        yield
        return
    real = frf_module._candidates

    def chosen(nominal):
        out, why = real(nominal)
        return [e for e in out if e.name in names], why
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(frf_module, "_candidates", chosen)
        yield


def test_receptance_diagnoses_as_the_accelerance(one_level):
    """The same campaign (same noise draws) as receptance: the same named effect and fit; the gap,
    a ratio of measurement and model, the same within 0.01 dB (measured 0.0001-0.001 dB: only the
    noise estimate differs, second differences of H / w^2 instead of H)."""
    _, ref = one_level("accelerometer_mass", "accelerance", only=ACC)
    d, res = one_level("accelerometer_mass", "receptance", only=ACC)
    assert json.loads((d / "frf_01.json").read_text())["quantity"] == "receptance"
    assert res["named_effect"] == ref["named_effect"] == "accelerometer_mass"
    for g in ("gap_before", "gap_after"):
        assert res[g]["structure_frf_db"] == pytest.approx(ref[g]["structure_frf_db"], abs=0.01)
    assert res["fitted_parameters"]["accelerometer_mass"] == pytest.approx(0.02, rel=0.01)
    assert res["sensors"]["a_tip_meas"] == {"point": "tip", "quantity": "receptance", "unit": "m/N"}


def test_mobility_of_any_sensors_paired_by_shape(one_level, tmp_path):
    """Velocity sensors of any name at positions without a model point (a massless point is added
    there): moving_mass named, every sensor in the gap over the whole band, the modes paired by
    shape (three sensors: MAC > 0.9 for all eight modes of the linear model); the report plots
    each sensor in its quantity."""
    from frictionrt.rt.discrepancy.diagnose.report import write_report
    d, res = one_level("moving_mass", "mobility_sensors", only=("moving_mass",))
    assert res["named_effect"] == "moving_mass", res["ranking"]
    assert res["sensors"]["v_mid"] == {"point": "v_mid", "quantity": "mobility", "unit": "(m/s)/N"}
    assert res["sensors"]["v_tip_laser"]["point"] == "tip"                   # the model's point within 1 mm
    g = res["gap_after"]["frf_01"]
    assert g["band_hz"] == [4.0, 1600.0] and g["frf_db_all"] < 0.5 < res["gap_before"]["frf_01"]["frf_db_all"]
    loc = res["localisation"]["frf_01"]
    assert loc["paired_by"] == "shape (MAC)" and all(m["mac"] > 0.9 for m in loc["modes"].values()), loc
    out = write_report(res, tmp_path / "rep")
    md = (out / "report.md").read_text()
    assert "| v_root | v_root | mobility | (m/s)/N |" in md and "a_frf" not in md.split("## Localisation")[0]
    # the rrd: per sensor, the whole band; the gap's rms over every sensor is frf_db_all
    from rerun.chunk import RrdReader
    gap = {}
    for c in RrdReader(out / "diagnosis.rrd").stream().to_chunks():
        if c.entity_path.startswith("/frf_gap/frf_01/") and c.entity_path.endswith("/after"):
            gap[c.entity_path.split("/")[3]] = c.to_record_batch().column("Scalars:scalars").flatten().to_numpy()
    assert sorted(gap) == sorted(THREE_SENSORS) and all(len(v) == 6385 for v in gap.values())
    assert np.sqrt(np.mean(np.concatenate(list(gap.values())) ** 2)) == pytest.approx(g["frf_db_all"], abs=1e-3)


def test_position_off_every_beam_is_refused(tmp_path):
    d = tmp_path / "c"
    make_frf_campaign(d, "none", seed=SEED, levels_n=ONE_LEVEL, sensors={"v_x": ("main", 0.3)})
    meta = json.loads((d / "frf_01.json").read_text())
    for x, msg in ((0.9, "sensor v_x at x = 0.9 m: no beam of the model holds that x (main [0, 0.775] m, damper "
                         "[0.465, 0.625] m)"),
                   (0.5, "sensor v_x at x = 0.5 m lies on beams main, damper; say which in the sidecar")):
        meta["sensor_positions_m"]["v_x"] = x
        (d / "frf_01.json").write_text(json.dumps(meta))
        with pytest.raises(ValueError, match=re.escape(msg)):
            diagnose_frf(d)


def test_drive_voltage_force_scale(one_level, tmp_path):
    """H per volt = 0.37 N/V x H per newton, no force: the scale fitted within 1 % (measured 0.01 %),
    the effect named as with a force, the JSON and report say the data have no force."""
    from frictionrt.rt.discrepancy.diagnose.report import write_report
    _, ref = one_level("clamp_compliance", "accelerance", only=CLAMP)
    d, res = one_level("clamp_compliance", "drive_voltage", only=CLAMP)
    assert json.loads((d / "frf_01.json").read_text())["excitation"] == "drive_voltage"
    assert res["named_effect"] == ref["named_effect"] == "clamp_compliance"
    assert res["excitation"]["force_scale_N_per_V"] == pytest.approx(0.37, rel=0.01)
    assert res["fitted_parameters"]["force_scale_N_per_V"] == res["excitation"]["force_scale_N_per_V"]
    assert res["gap_after"]["structure_frf_db"] == pytest.approx(ref["gap_after"]["structure_frf_db"], abs=0.01)
    assert res["fitted_parameters"]["E"] == pytest.approx(ref["fitted_parameters"]["E"], rel=1e-4)
    md = (write_report(res, tmp_path / "rep") / "report.md").read_text()
    assert "## Excitation: drive voltage, no force" in md and "cannot be separated" in md
    from frictionrt.rt.discrepancy.diagnose import summary
    assert "no force in the data: fitted force scale 0.37" in summary(res)


def test_force_scale_absorbs_the_mass_scale(one_level):
    """What no force leaves unidentifiable: every mass and stiffness by one factor. A nominal with
    the beams' density and E both x 1.2 (the same frequencies): the force scale comes out x 1.2
    (within 1 %: the screws' lumped masses did not scale), E as from the right nominal within 0.5 %
    (measured 0.2 %: the unscaled screw masses move the frequencies a little)."""
    c = with_sets(Config(), [])
    heavy = with_sets(c, [f"plant.beams.{b.name}.{k}={getattr(b, k) * 1.2!r}" for b in c.plant.beams
                          for k in ("rho", "E")])
    _, ref = one_level("clamp_compliance", "drive_voltage", only=CLAMP)
    _, res = one_level("clamp_compliance", "drive_voltage", heavy, only=CLAMP)
    assert res["excitation"]["force_scale_N_per_V"] == pytest.approx(0.37 * 1.2, rel=0.01)
    assert res["fitted_parameters"]["E"] == pytest.approx(ref["fitted_parameters"]["E"], rel=5e-3)


# the far high start (E+77 %, 45 s) in the suite; the low one (E-44 %, 72 s of one worker) and the starts
# between them in `make test-slow`
@pytest.mark.parametrize("e_nominal", [pytest.param(0.56, marks=pytest.mark.slow), pytest.param(0.7, marks=pytest.mark.slow),
                                       pytest.param(1.4, marks=pytest.mark.slow), 1.77],
                         ids=["E-44%", "E-30%", "E+40%", "E+77%"])
def test_calibration_from_far_away(one_level, e_nominal):
    """A nominal E 44 or 30 % low, 40 or 77 % high (frequencies -25 %, -16 %, +18 %, +33 %) whose user
    says so (diagnosis.uncertainty.E_rel = 0.9: E within nominal x 0.1..1.9; the default 0.05 would
    hold E near nominal and report it): every measured mode paired, E fitted to the campaign's true
    scatter within 1e-4 (measured 2e-6), the gap as from the right nominal within 0.01 dB, nothing
    outside its plausible range. Calibration alone (``trying_only(())``): the far start is its task."""
    nominal = scaled(with_sets(Config(), ["diagnosis.uncertainty.E_rel=0.9"]), {"E": e_nominal})
    true_E = scaled(Config(), scatter_sets(np.random.default_rng(SEED)))   # make_frf_campaign's first draws
    _, ref = one_level("none", "accelerance", only=())
    _, res = one_level("none", "accelerance", nominal, only=())
    assert res["warnings"] == []
    E_fit = res["fitted_parameters"]["E"] * e_nominal
    assert E_fit == pytest.approx(true_E.plant.beams[0].E / Config().plant.beams[0].E, rel=1e-4)
    modes = res["localisation"]["frf_01"]["modes"]
    assert all(m["f_measured_hz"] is not None for m in modes.values()), modes
    assert all(abs(m["shift_rel"] - (e_nominal ** -0.5 * math.sqrt(E_fit) - 1)) < 0.05 for m in modes.values())
    assert res["gap_after"]["structure_frf_db"] == pytest.approx(ref["gap_after"]["structure_frf_db"], abs=0.01)
    assert res["plausibility"]["calibration_outside"] == res["plausibility"]["outside"] == []


# k_t/10 takes ~2x k_t*10 (stage 2 walks a decade further on the stiff side of the range): `make test-slow`
@pytest.mark.parametrize("k_nominal", [pytest.param(0.1, marks=pytest.mark.slow), 10.0], ids=["k_t/10", "k_t*10"])
def test_contact_stiffness_a_decade_off(one_level, k_nominal):
    """A nominal k_t a factor 10 off (its log-scale range 0.01..100): stage 1 fits ln k_t on the
    frequencies with E, stage 2 (up to 30 steps) ends at the campaign's true k_t within 0.1 %
    (measured 0.001-0.01 %), the damping within 1 %, the gap as from the right nominal within
    0.01 dB, no warning. Calibration alone (``trying_only(())``)."""
    c = Config()
    nominal = with_sets(Config(), [f"plant.interface.k_t_area={c.plant.interface.k_t_area * k_nominal!r}"])
    true = scaled(c, scatter_sets(np.random.default_rng(SEED)))
    _, ref = one_level("none", "accelerance", only=())
    _, res = one_level("none", "accelerance", nominal, only=())
    assert res["warnings"] == []
    assert res["fitted_parameters"]["k_t"] * k_nominal == pytest.approx(
        true.plant.interface.k_t_area / c.plant.interface.k_t_area, rel=1e-3)
    assert res["fitted_parameters"]["modal_damping"] == pytest.approx(ref["fitted_parameters"]["modal_damping"], rel=0.01)
    assert res["gap_after"]["structure_frf_db"] == pytest.approx(ref["gap_after"]["structure_frf_db"], abs=0.01)


def test_parameter_on_a_bound_is_a_warning(one_level, tmp_path):
    """A nominal modal damping 20 x too high: the fit needs a scale ~0.05, below the bound 0.1, and
    ends on it: a warning in the JSON (parameter, value, bound, fix) and in report.md."""
    from frictionrt.rt.discrepancy.diagnose.report import write_report
    nominal = with_sets(Config(), ["plant.modal_damping=0.02"])
    _, res = one_level("none", "accelerance", nominal, only=())
    w = [x for x in res["warnings"] if x["parameter"] == "modal_damping"]
    assert len(w) == 1 and w[0]["bound"] == 0.1 and w[0]["value"] == pytest.approx(0.1, rel=0.005), res["warnings"]
    assert "check the nominal plant.modal_damping" in w[0]["fix"] and "drive_voltage" in w[0]["fix"]
    md = (write_report(res, tmp_path / "rep") / "report.md").read_text()
    assert "## Warnings: parameters on a bound, level" in md and "| modal_damping | 0.1 | 0.1 |" in md
    from frictionrt.rt.discrepancy.diagnose import summary
    assert "warning: modal_damping = 0.1 on its bound 0.1: check the nominal" in summary(res)   # the CLI's text


def test_bound_warnings_by_scale():
    """Within 0.5 % of a bound: relative to it, on ln for the log-scale ones, relative to the range
    for a bound 0; the fix of a level-like parameter hints at missing force unless per volt."""
    from frictionrt.rt.discrepancy.diagnose.frf import bound_warnings
    eff = get("clamp_compliance")
    w = bound_warnings({"E": 1.995, "k_t": 0.01004, "modal_damping": 9.9, "clamp_compliance": 1e-6,
                        "force_scale_N_per_V": 999.0}, eff, True, Config())
    assert [(x["parameter"], x["bound"]) for x in w] == [("E", 2.0), ("k_t", 0.01), ("clamp_compliance", 0.0),
                                                         ("force_scale_N_per_V", 1000.0)]
    assert all("drive_voltage" not in x["fix"] for x in w)
    assert bound_warnings({"E": 1.98}, None, False, Config()) == []
    assert "drive_voltage" in bound_warnings({"E": 0.5}, None, False, Config())[0]["fix"]


def test_voltage_data_taken_as_force_warn_of_the_level(one_level, tmp_path):
    """The issue's trap: FRFs per volt (0.37 N/V: -8.6 dB) with a sidecar that says force. No
    calibration parameter moves the level everywhere, so the fit ends that far off (measured
    -8.3 dB, the damping taking a little) and a warning names the level and the drive voltage."""
    import shutil
    src, _ = one_level("clamp_compliance", "drive_voltage", only=CLAMP)
    d = tmp_path / "as_force"
    shutil.copytree(src, d)
    meta = json.loads((d / "frf_01.json").read_text())
    del meta["excitation"]
    (d / "frf_01.json").write_text(json.dumps(meta))
    with trying_only(CLAMP):
        res = diagnose_frf(d)
    assert -8.64 < res["level_offset_db"] < -6.0
    w = [x for x in res["warnings"] if x["parameter"] == "level_offset_db"]
    assert len(w) == 1 and w[0]["bound"] is None and "set the sidecar's excitation to drive_voltage" in w[0]["fix"]
    assert "excitation" not in res


def test_rig_cli_writes_the_file_kinds(tmp_path, capsys):
    """rig --frf-files --quantity mobility --force-scale 0.37: sidecars say so, the data are the
    accelerance campaign's (same seed, same noise draws) / (i w) x 0.37 to the CSV's bits; the
    options without --frf-files or a scale <= 0 are refused in one line."""
    from frictionrt.rt.log.frf_files import read_frf
    for extra, d in (([], tmp_path / "a"), (["--quantity", "mobility", "--force-scale", "0.37"], tmp_path / "v")):
        assert main(["rig", "--effect", "none", "--frf-files", "--seed", "1", "-o", str(d)] + extra) == 0
    capsys.readouterr()
    a, v = read_frf(tmp_path / "a" / "frf_01.csv"), read_frf(tmp_path / "v" / "frf_01.csv")
    assert (v.quantity, v.excitation, v.unit, v.meta["amplitude_n"]) == ("mobility", "drive_voltage", "(m/s)/V", None)
    for s in a.H:
        assert np.max(np.abs(v.H[s] / (0.37 * a.H[s] / (2j * np.pi * a.freq_hz)) - 1)) < 1e-14
    for argv in (["--quantity", "receptance"], ["--frf-files", "--force-scale", "0"]):
        assert main(["rig", "--effect", "none", "-o", str(tmp_path / "x")] + argv) == 2
        assert len(capsys.readouterr().err.strip().splitlines()) == 1 and not (tmp_path / "x").exists()


def test_an_interrupted_diagnosis_keeps_its_fits(tmp_path, capsys, monkeypatch):
    """Ctrl-C in the second candidate's fit (patched to raise it): exit 130, the report folder holds the two
    fits done (calibration only and the first candidate; diagnose.json as printed, model.toml the candidate's
    configuration), the fits' progress bars and the wall time are on stderr, no traceback."""
    import frictionrt.rt.discrepancy.diagnose.frf as frf
    from frictionrt.rt.discrepancy.diagnose.frf import _candidates
    d = tmp_path / "c"
    make_frf_campaign(d, "none", seed=SEED, levels_n=ONE_LEVEL)
    first = _candidates(Config())[0][0]
    real = frf.fit

    def stopping(nominal, data, effect, *args, **kwargs):
        if effect is not None and effect is not first:
            raise KeyboardInterrupt
        return real(nominal, data, effect, *args, **kwargs)
    monkeypatch.setattr(frf, "fit", stopping)
    out = tmp_path / "report"
    assert main(["diagnose", str(d), "--json", "--out", str(out)]) == 130
    printed, err = capsys.readouterr()
    res = json.loads(printed)
    assert res["interrupted"] and res["input"] == "frf_files" and list(res["fits"]) == ["calibration only", first.name]
    assert sorted(f.name for f in out.iterdir()) == ["diagnose.json", "model.toml", "report.md"]
    assert json.loads((out / "diagnose.json").read_text()) == res
    E = res["fits"][first.name]["fitted"]["E"]
    assert load(out / "model.toml").plant.beams[0].E == pytest.approx(E * Config().plant.beams[0].E, rel=1e-4)
    assert "calibration only: " in err and "model" in err and "the 2 fits done so far are in" in err
    assert "Traceback" not in err and err.rstrip().splitlines()[-1].endswith(" s wall")


# --- the shaker as a two-port on FRF files per drive volt ----------------------------------------------

def shaker_against_calibration(cal, sh) -> list[dict]:
    """``campaign.rank``'s input for calibration alone and the shaker candidate on FRF files (its BIC
    scored on the FRF channels, as the diagnosis groups it)."""
    from frictionrt.rt.discrepancy.diagnose.campaign import bic
    from frictionrt.rt.discrepancy.diagnose.frf import SHAKER
    return [{"effect": None, "theta": cal.theta, "channels": cal.channels, "score": bic(cal.channels, len(cal.theta))},
            {"effect": SHAKER, "theta": sh.theta, "channels": sh.channels, "group": "FRF",
             "score": bic(sh.channels, len(sh.theta))}]


def test_a_voltage_driven_shaker_is_named_on_frfs_per_volt(tmp_path, capsys):
    """A truth driven by a voltage-mode shaker (armature 0.15 kg, Bl 12 N/A, R 1.5 ohm: c_e = Bl^2 / R =
    96 N s/m; the nominal's catalogue Bl is 10 N/A, 67 N s/m) at the bare beam's excitation point (the
    cheapest structure: the shaker's physics is the drive point's), FRFs per drive volt (10 N/V):
    the calibration alone, then the shaker's fit from the catalogue start; the ranking names the shaker
    with its armature mass and c_e within 20 % (measured 0.1500 kg, 96.08 N s/m, 10.0003 N/V, dBIC 1.2e5,
    on seed 1; the full diagnosis with the structural candidates on the paper's structure:
    benchmarks/shaker_two_port.py). The control, an ideal source per volt, names nothing. Per newton
    (force measured) the rig refuses the effect: the data need no shaker model."""
    from frictionrt.rt.discrepancy.diagnose.campaign import rank
    from frictionrt.rt.discrepancy.diagnose.frf import BACK_EMF, SHAKER, fit, fit_shaker_frf
    nominal = load(CONFIGS / "bare_beam.toml")
    truth = with_sets(nominal, ["shaker.amplifier=voltage", "shaker.force_constant_N_per_A=12.0"])
    d = tmp_path / "shaker"
    make_frf_campaign(d, "shaker_interaction", 0.15, seed=1, cfg=truth, force_scale_N_per_V=10.0)
    data = prepare(load_frf_folder(d), nominal)
    cal = fit(nominal, data, None)
    sh = fit_shaker_frf(nominal, data, cal)
    results = shaker_against_calibration(cal, sh)
    _, _, winner = rank(results)
    assert winner is not None and winner["effect"] == SHAKER, results[1]["score"] - results[0]["score"]
    assert sh.theta[SHAKER] == pytest.approx(0.15, rel=0.2)
    assert sh.theta[BACK_EMF] == pytest.approx(12.0 ** 2 / 1.5, rel=0.2)
    assert sh.cfg.shaker.amplifier == "voltage" and sh.cfg.shaker.armature_mass_kg == pytest.approx(sh.theta[SHAKER])
    # the control: an ideal source per volt (no shaker in the truth) names nothing
    make_frf_campaign(tmp_path / "ideal", "none", seed=1, cfg=nominal, force_scale_N_per_V=10.0)
    data = prepare(load_frf_folder(tmp_path / "ideal"), nominal)
    cal = fit(nominal, data, None)
    sh = fit_shaker_frf(nominal, data, cal)
    results = shaker_against_calibration(cal, sh)
    assert rank(results)[2] is None, (sh.theta, results[0]["score"] - results[1]["score"])
    assert main(["rig", "--effect", "shaker_interaction", "--frf-files", "-o", str(tmp_path / "n")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--force-scale" in err[0] and not (tmp_path / "n").exists()


def test_a_current_driven_shaker_is_fitted_in_its_mode(tmp_path):
    """A nominal that describes its shaker in current mode (armature 0.1 kg, the catalogue's) gets the
    current-driven candidate: the armature mass alone (no back-EMF term), found on a truth of 0.15 kg per
    drive volt (bare beam, seed 2; measured 0.1500 kg, 10.001 N/V, dBIC 1.2e5, named)."""
    from frictionrt.rt.discrepancy.diagnose.campaign import rank
    from frictionrt.rt.discrepancy.diagnose.frf import BACK_EMF, SHAKER, fit, fit_shaker_frf
    bare = load(CONFIGS / "bare_beam.toml")
    nominal = with_sets(bare, ["shaker.armature_mass_kg=0.1"])
    make_frf_campaign(tmp_path / "cur", "shaker_interaction", 0.15, seed=2, cfg=bare, force_scale_N_per_V=10.0)
    data = prepare(load_frf_folder(tmp_path / "cur"), nominal)
    cal = fit(nominal, data, None)
    sh = fit_shaker_frf(nominal, data, cal)
    results = shaker_against_calibration(cal, sh)
    assert rank(results)[2] is not None
    assert BACK_EMF not in sh.theta and sh.cfg.shaker.amplifier == "current"
    assert sh.theta[SHAKER] == pytest.approx(0.15, rel=0.2)
