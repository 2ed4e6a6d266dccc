"""diagnose --calibrate-on (rt/discrepancy/diagnose/levels.py): FRFs of the nonlinear plant at several
levels, calibrated at the lowest, predicted at the others by the harmonic balance of the joints and by
the linear stuck model."""
from __future__ import annotations

import json

import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.discrepancy.diagnose.levels import diagnose_levels, split
from frictionrt.rt.discrepancy.rig.levels import make_level_campaign
from frictionrt.rt.log.frf_files import load_frf_folder

SCALE = 0.37                  # [N/V] the shaker's force per drive volt
LEVELS = (1.35, 2.7, 27.0)    # [V]: 0.5, 1, 10 N


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """Mode 3's band only (16 lines a level): the level tests of the benchmark, no hidden effect, seed 3,
    driven by a voltage without force transducer (the force scale is to be fitted)."""
    out = tmp_path_factory.mktemp("levels") / "c"
    make_level_campaign(out, "none", seed=3, force_levels_n=LEVELS, band_hz=(190.0, 270.0),
                        force_scale_N_per_V=SCALE)
    return out


@pytest.mark.slow   # the same diagnosis with the candidates' fits (micro_slip, the clamp: ~40 % of its CPU)
def test_no_candidate_is_named_on_a_campaign_without_an_effect(folder, tmp_path, capsys):
    """The whole diagnosis of the campaign below (no hidden effect): neither candidate (micro_slip,
    clamp_compliance) is named, and the prediction is the calibration's (the suite's twin below)."""
    res = _levels_cli(folder, tmp_path, capsys)
    assert res["named_effect"] is None and {r["effect"] for r in res["ranking"]} == {"micro_slip", "clamp_compliance"}
    _assert_predicts_the_higher_level(res, tmp_path / "report")


def test_the_harmonic_balance_predicts_the_higher_level(folder, tmp_path, capsys, monkeypatch):
    """The suite's twin of the test above, calibration alone (the candidates' fits are ~40 % of the
    diagnosis's CPU, profiled, and nothing here asserts on them): see ``_assert_predicts_the_higher_level``."""
    import frictionrt.rt.discrepancy.diagnose.levels as levels
    monkeypatch.setattr(levels, "CANDIDATES", ())
    res = _levels_cli(folder, tmp_path, capsys)
    assert res["named_effect"] is None and res["ranking"] == []
    _assert_predicts_the_higher_level(res, tmp_path / "report")


def _levels_cli(folder, tmp_path, capsys) -> dict:
    """diagnose --calibrate-on 1.35,2.7 --json --out tmp_path/report on ``folder``: the printed result."""
    assert main(["diagnose", str(folder), "--calibrate-on", "1.35,2.7", "--json", "--out", str(tmp_path / "report")]) == 0
    return json.loads(capsys.readouterr().out)


def _assert_predicts_the_higher_level(res: dict, out) -> None:
    """Calibrated on 1.35 and 2.7 V (0.5 and 1 N), the harmonic balance predicts the 27 V FRF at least 3x
    closer than the linear model calibrated on the same files, with the force scale within 5 % (the issue's
    figure; 15 % here until issue 32, for the whole plan's +9 % on the earlier plant), and it is
    the softening mode the report finds; the linear model's damping ends on its bound (10) and is warned;
    at the calibration levels the harmonic balance fits no worse than the linear model by their common
    objective (measured: 0.81 against 12.32; 27 V at 1.09 against 9.76 dB with both fitted on the bands).
    Measured on the converged plant (issue 32; mode 3's band only, 16 lines a level; 65 s on a shared
    2-core machine): 27 V at 1.09 against 9.77 dB (9.0x), force scale 0.3662 (-1.0 %). Issue 31's 7.24
    against 9.86 dB (measured at 76c42ef, on the uniform 10 mm default before the graded one) no longer holds. (On the earlier per-pair plant: 0.94 against 9.91 dB here, and the
    whole 50-1200 Hz plan of seed 3 0.75 against 10.44 dB with the scale +9 %: there k_t, mu and the
    damping trade with it, with method aft as well: docs/discrepancy.md.) The 3x and the 5 % are the
    issue's figures, not re-tuned: the measured 9.0x and -1.0 % are well inside."""
    assert res["softening_mode"] == 3 and res["calibrate_on_n"] == [1.35, 2.7] and res["level_unit"] == "V"
    assert res["nonlinear"]["fitted"]["force_scale_N_per_V"] == pytest.approx(SCALE, rel=0.05)
    assert {(w["model"], w["parameter"]) for w in res["warnings"]} >= {("linear", "modal_damping")}
    p = {x["level_n"]: x for x in res["prediction"]}
    assert not p[27.0]["calibrated_on"] and p[1.35]["calibrated_on"]
    assert p[27.0]["gap_linear_db"] > 3.0 * p[27.0]["gap_nonlinear_db"], p[27.0]
    assert p[27.0]["better"] == "nonlinear"
    # at the calibration levels, by the objective both models are fitted on (the modes' bands), the harmonic
    # balance is no worse than its stuck limit, the linear model; so it is not refused
    c = res["calibration_gap"]
    assert c["nonlinear"] <= c["linear"] and not c["refused"] and not res["nonlinear"]["stuck_limit"], c
    # the contact opens at 27 V (df's note): predicted there by aft from the df calibration too, and aft, which
    # holds the opening, is closer than the linear model
    assert p[27.0]["normal_ratio_max"] > 1.0 and "gap_aft_db" in p[27.0] and "predicted there by aft" in res["contact_note"]
    assert p[27.0]["gap_aft_db"] < p[27.0]["gap_linear_db"], p[27.0]
    assert sorted(f.name for f in out.iterdir()) == ["diagnose.json", "levels.png", "model.toml", "report.md"]
    assert json.loads((out / "diagnose.json").read_text()) == res


def test_levels_are_checked(folder, tmp_path, capsys):
    tests = load_frf_folder(folder)
    with pytest.raises(ValueError, match="no test at that level; the folder's levels"):
        split(tests, [2.0])
    with pytest.raises(ValueError, match="leave at least one to predict"):
        split(tests, LEVELS)
    with pytest.raises(ValueError, match="one excitation level"):
        split(tests[:1], [1.35])
    for argv, words in (([str(folder), "--calibrate-on", "x"], "comma-separated numbers"),
                        ([str(tmp_path), "--calibrate-on", "1"], "not a folder of FRF files")):
        assert main(["diagnose", *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert words in err and "\n" not in err, err
    with pytest.raises(ValueError, match="no test at that level"):
        diagnose_levels(folder, [3.0])
    # a drive-voltage sidecar's level is in V and only with that excitation
    from frictionrt.rt.log.frf_files import check_meta
    meta = dict(tests[0].meta) | {"excitation": "force"}
    with pytest.raises(ValueError, match="drive_amplitude_v is given, but the excitation is a force"):
        check_meta(meta)


def test_the_fit_uses_the_modes_bands_each_weighted_alike():
    """mode_bands: a dense band (100 lines at 0.4 Hz around 200 Hz) and a sparse one (10 lines around
    50 Hz, an unpaired measured mode) are kept, the lines between them left out; each band's weights
    w = sigma_k^2 / sigma_k'^2 sum to n / B = 55 (the sparse band's lines weigh 10x the dense band's)."""
    import numpy as np

    from frictionrt.rt.discrepancy.diagnose.frf import FRFData
    from frictionrt.rt.discrepancy.diagnose.levels import mode_bands
    freq = np.concatenate([np.linspace(46.0, 54.0, 10), np.linspace(100.0, 150.0, 20), 180.2 + 0.4 * np.arange(100)])
    H = {"v": np.ones(len(freq)) + 0j}
    sel = {"v": np.ones(len(freq), bool)}
    d = FRFData("t", 100.0, freq, H, sel, {"v": np.zeros(len(freq))}, {"v": np.full(len(freq), 0.02)},
                {"measured": np.array([200.0, np.nan])}, unpaired_hz=(50.0,))
    b = mode_bands(d)
    assert len(b.freq) == 110 and b.freq[9] == 54.0 and b.freq[10] == 180.2
    w = (0.02 / b.sigma["v"]) ** 2
    assert w[:10].sum() == pytest.approx(55.0, rel=1e-12) and w[10:].sum() == pytest.approx(55.0, rel=1e-12)
    assert w[0] / w[-1] == pytest.approx(10.0, rel=1e-12)


def test_an_interrupted_diagnosis_keeps_its_fits(folder, tmp_path, capsys, monkeypatch):
    """Ctrl-C inside the harmonic-balance fit (the 11th model evaluation: after 5 whole ones on the two
    calibration levels): exit 130, the report folder holds the linear fit and the interrupted fit's best
    point (diagnose.json as printed, model.toml that point's configuration), the fit's progress bar and
    the wall time are on stderr."""
    import frictionrt.rt.discrepancy.diagnose.levels as levels
    from frictionrt.rt.common.config import load
    calls = []

    def stopping(*args, **kwargs):
        calls.append(1)
        if len(calls) == 11:
            raise KeyboardInterrupt
        return real(*args, **kwargs)
    real = levels.level_accelerances
    monkeypatch.setattr(levels, "level_accelerances", stopping)
    out = tmp_path / "report"
    assert main(["diagnose", str(folder), "--calibrate-on", "1.35,2.7", "--json", "--out", str(out)]) == 130
    printed, err = capsys.readouterr()
    res = json.loads(printed)
    stopped = "harmonic balance (interrupted: its best point so far)"
    assert res["interrupted"] and list(res["fits"]) == ["linear", stopped]
    assert res["fits"][stopped]["evaluations"] == 5
    assert sorted(f.name for f in out.iterdir()) == ["diagnose.json", "model.toml", "report.md"]
    assert json.loads((out / "diagnose.json").read_text()) == res
    mu = res["fits"][stopped]["fitted"]["mu"]
    assert load(out / "model.toml").plant.interface.mu == pytest.approx(0.4 * mu, rel=1e-4)
    assert "harmonic balance: 5model" in err and "the 2 fits done so far are in" in err
    assert err.rstrip().splitlines()[-1].endswith(" s wall")


def test_a_harmonic_balance_fit_worse_than_its_stuck_limit_is_refused(folder, monkeypatch):
    """calibration_gap's rule: the harmonic balance with its joints stuck is the linear model, so a
    harmonic-balance fit that ends worse than the linear fit on the same lines (here forced: each fit
    returns mu x 0.2 from its start, the joint slipping far too early) is refused; the stuck limit is
    kept, so the nonlinear model's gaps equal the linear model's at every level and nothing is named."""
    import numpy as np

    import frictionrt.rt.discrepancy.diagnose.levels as levels
    from frictionrt.rt.discrepancy.diagnose.frf import weighted_residuals
    from frictionrt.rt.discrepancy.diagnose.levels import calibration_gap

    assert calibration_gap({"a": np.array([1.0, 1.0])}, {"a": np.array([1.0, 1.001])})["refused"]
    assert not calibration_gap({"a": np.array([1.0, 1.0])}, {"a": np.array([1.0, 1.0])})["refused"]

    def slipping(nominal, data, lv, start, effect, method="df", bars=False):
        theta = {k: start.get(k, 1.0) for k in levels.CAL_NAMES} | {"mu": 0.2} | (
            {k: v for k, v in start.items() if k == levels.FORCE_SCALE}) | (
            {effect.name: effect.nominal} if effect else {})
        cfg = levels._cfg(nominal, theta, effect)
        H = levels.nonlinear_H(cfg, data, lv, theta.get(levels.FORCE_SCALE, 1.0), method)
        return {"theta": theta, "channels": weighted_residuals(data, H, profile_scale=False)[0], "cfg": cfg,
                "evaluations": 1}
    monkeypatch.setattr(levels, "fit_nonlinear", slipping)
    res = diagnose_levels(folder, [1.35, 2.7])
    c = res["calibration_gap"]
    assert c["refused"] and c["nonlinear"] > c["linear"] and res["nonlinear"]["stuck_limit"], c
    assert res["named_effect"] is None and "mu" not in res["nonlinear"]["fitted"] and res["contact_note"] is None
    for p in res["prediction"]:
        assert p["gap_nonlinear_db"] == p["gap_linear_db"] and p["better"] == "linear", p
