"""What the diagnosis shows people (rt.discrepancy.diagnose): the gap's shares add up to 100 % with a
remainder within the noise said in words, the overlays carry a residual panel in dB, and the text
on stdout is rounded to the digits that mean something (``--json`` keeps full precision). Fast: no
fit runs, the results are made by hand."""
from __future__ import annotations

import re

import numpy as np
import pytest

from frictionrt.rt.discrepancy.diagnose.remainder import budget, percent_split, verdict


def _channels(rss: float, n: int = 100) -> dict:
    """A structure channel of n equal weighted residuals whose sum of squares is ``rss``."""
    return {"FRF a_tip_meas": np.full(n, np.sqrt(rss / n))}


def _verdict(r0: float, rc: float, rf: float, named="moving_mass") -> tuple[str, dict]:
    b = budget(_channels(r0), _channels(rc), _channels(rf), {})
    return verdict({"gap_budget": b, "named_effect": named, "ranking": []}), b


def _percents(text: str) -> list[int]:
    return [int(p) for p in re.findall(r"(\d+) %", text)]


def test_shares_add_to_100_with_a_remainder_within_the_noise():
    # n = 100 residuals: RSS_0 = 1000, calibration leaves 130, the effect 50 < n: before, "calibration
    # explains 97 %, the named effect 9 % and 0 % remains" (870/900, 80/900, clipped -50/900)
    text, b = _verdict(1000.0, 130.0, 50.0)
    assert b["remainder_within_noise"] and b["remainder_share"] == 0.0
    assert b["calibration_share"] + b["effect_share"] == pytest.approx(1.0, abs=1e-4)
    assert b["calibration_share"] == pytest.approx(870 / 950, abs=1e-4)   # of what was explained, RSS_0 - RSS_f
    assert _percents(text) == [92, 8] and "within the noise" in text, text


def test_shares_add_to_100_when_a_remainder_is_left():
    # a third each of the excess 900 (RSS 1000 -> 700 -> 400, n = 100): 33 + 33 + 33 = 99 unless rounded as a whole
    text, b = _verdict(1000.0, 700.0, 400.0)
    assert not b["remainder_within_noise"] and sum(_percents(text)) == 100 and "within the noise" not in text, text
    assert _percents(text) == [34, 33, 33]
    # a remainder 2 standard deviations of chi-square(n) above n is noise, one above that is not
    n, sd = 100, np.sqrt(200.0)
    assert _verdict(1000.0, 500.0, n + 2 * sd - 1e-9)[1]["remainder_within_noise"]
    assert not _verdict(1000.0, 500.0, n + 2 * sd + 1.0)[1]["remainder_within_noise"]


def test_percent_split():
    assert percent_split([1 / 3, 1 / 3, 1 / 3]) == [34, 33, 33]
    assert percent_split([0.97, 0.09, -0.06]) == [92, 8, 0]      # a negative share is none; the rest scaled to 100
    assert percent_split([0.0, 0.0, 0.0]) == [0, 0, 0]
    rng = np.random.default_rng(0)
    assert all(sum(percent_split(rng.uniform(0, 1, 3))) == 100 for _ in range(200))


# --- the overlays ---------------------------------------------------------------------------------

def test_overlay_has_a_residual_panel_in_db():
    import matplotlib
    matplotlib.use("Agg")
    from frictionrt.rt.discrepancy.diagnose.overlay import MODELS, overlay_figure
    f = np.linspace(10.0, 1000.0, 50)
    H = (1.0 + 0.5j) / (1.0 - (f / 300.0) ** 2 + 0.02j * f / 300.0)
    # before and after 0.1 dB apart: on top of each other in |H|, 0.1 dB apart below
    H0, H1 = H * 10 ** (0.1 / 20), H * np.exp(0.3j)
    fig = overlay_figure("t", [("|H|", f, H, {"before": H0, "after": H1})], MODELS)
    top, res = fig.axes
    assert res.get_ylabel().endswith("[dB]")
    lines = {ln.get_label(): ln.get_ydata() for ln in res.get_lines() if not ln.get_label().startswith("_")}
    np.testing.assert_allclose(lines[MODELS["before"][0]], -0.1, atol=1e-12)  # measured - model: -20 log10 10^(0.1/20)
    np.testing.assert_allclose(lines[MODELS["after"][0]], 0.0, atol=1e-12)    # a phase alone: 0 dB
    assert len(top.get_lines()) == 3


def test_report_overlays_of_frf_files_have_residual_panels(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from frictionrt.rt.discrepancy.diagnose import report
    from frictionrt.rt.discrepancy.diagnose.overlay import MODELS
    f = np.linspace(10.0, 1000.0, 50)
    H = {"a_tip_meas": np.ones(50, complex), "a_frf_meas": 2 * np.ones(50, complex)}
    pl = {"frf_units": {"t1": "(m/s^2)/N"}, "frf_quantity": {"t1": "accelerance"},
          "frf": [("t1", 100.0, f, H, {k: 2 * v for k, v in H.items()}, H)]}
    figs = []
    real = plt.Figure.savefig
    try:
        plt.Figure.savefig = lambda self, *a, **k: (figs.append(self), real(self, *a, **k))[1]
        assert report._plots({"_plots": pl}, tmp_path) == ["frf_t1.png"]
    finally:
        plt.Figure.savefig = real
    (fig,) = figs
    assert len(fig.axes) == 4 and [ax.get_ylabel().endswith("[dB]") for ax in fig.axes] == [False, True] * 2
    before = next(ln for ln in fig.axes[1].get_lines() if ln.get_label() == MODELS["before"][0])
    np.testing.assert_allclose(before.get_ydata(), -20 * np.log10(2.0), rtol=1e-12)   # the model 2x the measurement
    assert (tmp_path / "frf_t1.png").stat().st_size > 1000


# --- the text for people -------------------------------------------------------------------------

FITTED = {"E": 1.00251, "k_t": 1.0321, "modal_damping": 1.0112, "moving_mass": 0.050002,
          "clamp_compliance": 4.5264e-31, "accelerometer_mass": 0.0099596}


def test_fitted_values_for_people():
    from frictionrt.rt.discrepancy.diagnose.watch import fitted_text
    # 4 significant digits of the scale: 1 for the calibration's factors, the effect's default strength
    # (moving_mass 0.05 kg, clamp_compliance 3e-5 rad/(N m): 4.5e-31 of it is the bound 0, accelerometer_mass 0.02 kg)
    assert fitted_text(FITTED) == ("E 1.003, k_t 1.032, modal_damping 1.011, moving_mass 0.05, clamp_compliance 0, "
                                   "accelerometer_mass 0.00996")


def test_diagnose_summary_is_rounded_and_json_is_not():
    """The summary of a result as diagnose prints it: the fitted values rounded for people (before: their
    JSON, "clamp_compliance": 4.5264e-31); public(), what --json prints, keeps the result's values."""
    from frictionrt.rt.discrepancy.diagnose.campaign import public, summary
    text, b = _verdict(1000.0, 130.0, 50.0)
    res = {"named_effect": "moving_mass", "runner_up": "accelerometer_mass", "gap_budget": b,
           "ranking": [{"effect": "moving_mass", "delta_bic": 280254.53, "rss_reduction": 0.99912, "fitted": FITTED}],
           "gap_before": {"structure_frf_db": 3.07812, "actuator_nrmse": None},
           "gap_after": {"structure_frf_db": 0.17321, "actuator_nrmse": None}}
    out = summary(res)
    assert "fitted E 1.003, k_t 1.032, modal_damping 1.011, moving_mass 0.05, clamp_compliance 0," in out, out
    assert "e-31" not in out and "structure FRF gap [dB]: 3.078 -> 0.173" in out
    assert "0.050002" not in out and "1.0321" not in out, out
    assert public(res)["ranking"][0]["fitted"] == FITTED


def test_rig_list_is_rounded(capsys):
    from frictionrt.rt.cli.app import main
    assert main(["rig", "--list"]) == 0
    out = capsys.readouterr().out
    assert "accelerometer_mass   mass_kg [kg] default 0.02, bounds 0..0.2" in out, out


def test_levels_report_has_residual_panels(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from frictionrt.rt.discrepancy.diagnose.levels_report import write_levels_report
    f = np.linspace(50.0, 1200.0, 40)
    H = {"a_frf_meas": np.full(40, 3.0 + 0j)}
    plots = [(f"level_0{j}", a, f, H, {"a_frf_meas": H["a_frf_meas"] * 10 ** (a / 20)}, H) for j, a in enumerate((1.0, 2.0))]
    res = {"_plots": plots, "level_unit": "N", "calibrate_on_n": [1.0], "softening_band_hz": [100.0, 200.0],
           "prediction": [], "softening_mode": 3, "named_effect": None, "harmonic_method": "df", "contact_note": None,
           "nonlinear": {"fitted": {"E": 1.0}}, "linear": {"fitted": {"E": 1.0}}, "warnings": [],
           "calibration_gap": {"linear": 2.0, "nonlinear": 1.5, "refused": False},
           "plausibility": {"note": "fine", "let_go": None, "ranges": {}}}
    figs = []
    real = plt.Figure.savefig
    try:
        plt.Figure.savefig = lambda self, *a, **k: (figs.append(self), real(self, *a, **k))[1]
        write_levels_report(res, tmp_path / "rep")
    finally:
        plt.Figure.savefig = real
    (fig,) = figs
    assert len(fig.axes) == 4 and (tmp_path / "rep" / "levels.png").is_file()
    linear = [next(ln for ln in ax.get_lines() if ln.get_label() == "linear (stuck)") for ax in fig.axes[1::2]]
    for ln, a in zip(linear, (1.0, 2.0)):   # the linear model a dB above the measurement: measured - model = -a
        np.testing.assert_allclose(ln.get_ydata(), -a, rtol=1e-12)
