"""The discrepancy workflow on campaigns with a hidden effect (issue 7): rt.discrepancy.rig writes the campaign,
rt.discrepancy.diagnose must name the effect, fit its strength and close the gap; --effect none names nothing;
the files validate and do not reveal the effect. Seed 5 was not used while developing the method
(development used seeds 3, 11 and 17; seed 5 was run once, after)."""
import json
import os

import numpy as np
import pytest
from mcap.reader import make_reader
from threadpoolctl import threadpool_limits

from frictionrt.rt.cli import main
import frictionrt.rt.discrepancy.diagnose.campaign as campaign_module
from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.log.data_format import validate
from frictionrt.rt.log.mcap_log import start_time_ns
from frictionrt.rt.discrepancy.diagnose.campaign import (
    CONTINUE_ROUNDS, MIN_RSS_REDUCTION, NAME_THRESHOLD, SS_CHANNEL, bic, diagnose, fit_actuator, fit_in_parallel,
    fit_shaker, gaps, load_campaign, load_stepsine, nrmse_std, prepare_stepsine, rank, run_actuator_tests,
    stepsine_gap_db, stepsine_residuals, with_actuator)
from frictionrt.rt.discrepancy.diagnose.structure import SENSORS, best_nested, fit_structure, prepare, run_shape
from frictionrt.rt.discrepancy.effects import EFFECTS, get, implemented
from frictionrt.rt.discrepancy.chain import scaled
from frictionrt.rt.discrepancy.rig import make_campaign, scatter_sets

SEED = 5
# The workflow's tests run on the uniform 10 mm joint (end_refinement = 1: the same physical model
# less refined, its plant step ~1.7x cheaper than the graded default's, docs/plant.md 6.3), so that
# the suite keeps its budget; Stribeck's runs on the default, where the refit rounds were needed.
UNIFORM = "plant.interface.end_refinement=1"


def _nominal(effect: str) -> Config:
    """The nominal model of ``effect``'s campaign and diagnosis."""
    return with_sets(Config(), [] if effect == "stribeck" else [UNIFORM])


@pytest.fixture(scope="module", autouse=True)
def shared_structure_fits(shared_results):
    """The diagnoses here share their structure fits (conftest's ``shared_results``: once per run,
    for both xdist workers). The impulse tests of the campaigns none, current_limit and
    shaker_interaction are the same bits (same seed; those effects act on the actuator ramps and the
    step-sine tests only), and the structure fit (``fit_structure``: calibration, the structural
    candidates, the refits) is a pure function of the nominal and those tests, so three diagnoses
    ran it alike (154 s of a diagnosis' 168 s, profiled on one core). Keyed on every argument (the
    nominal's repr, the prepared FRFs, the effect's name, the calibrated fit, the start), a
    diagnosis gets the very fit it would compute; a worker waits for a fit the other is computing."""
    compute = campaign_module.fit_structure

    def shared(nominal, data, effect, calibrated=None, start=None, bars=False):
        # bars (progress on stderr) does not change the fit: not part of the key
        key = ("fit_structure", repr(nominal), data, effect.name if effect else None, calibrated, start)
        return shared_results(key, lambda: compute(nominal, data, effect, calibrated=calibrated, start=start,
                                                   bars=bars))

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(campaign_module, "fit_structure", shared)
        yield


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    cache = {}

    def get(effect: str):
        if effect not in cache:   # step-sine tests only where the effect needs them (they cost ~15-40 s)
            stepsine = effect != "none" and EFFECTS[effect].channel == "stepsine"
            cache[effect] = make_campaign(tmp_path_factory.mktemp(effect) / "c", effect, seed=SEED,
                                          cfg=_nominal(effect), stepsine=stepsine)[0].parent
        return cache[effect]
    return get


@pytest.fixture(scope="module")
def short_campaigns(tmp_path_factory):
    """The campaigns of the stage twins: the actuator and step-sine tests as ``campaigns`` makes them
    (their own seeds: the same bits), one 0.1 s impulse test (``load_campaign`` needs one) instead of
    three of 1 s, whose truth runs cost most of a campaign (~60 s of CPU)."""
    cache = {}

    def get(effect: str):
        if effect not in cache:
            stepsine = effect != "none" and EFFECTS[effect].channel == "stepsine"
            cache[effect] = make_campaign(tmp_path_factory.mktemp(f"short_{effect}") / "c", effect, seed=SEED,
                                          cfg=_nominal(effect), stepsine=stepsine, record_s=0.1)[0].parent
        return cache[effect]
    return get


@pytest.fixture(scope="module")
def diagnosed(campaigns):
    cache = {}

    def get(effect: str):
        if effect not in cache:
            cache[effect] = diagnose(campaigns(effect), _nominal(effect))
        return cache[effect]
    return get


# The whole diagnosis of micro_slip passed on the converged plant (issue 32, stop 43, measured once on this
# shared 2-core machine: named, dBIC 10509, 65 % of the FRF RSS, runner-up accelerometer_mass 490 / 5 %;
# spread 0.515 for 0.5; FRF gap 2.84 -> 0.45 dB; not re-run since the slip candidates' joint start of stop 44,
# after which its own fit below gives dBIC 4286, 36.1 %, spread 0.522) but takes 204 s with two processes,
# ~2x that serially in an xdist worker: over the suite's budget, so it runs in `make test-slow` only and
# the suite runs test_micro_slip_fit_names_it_against_calibration_alone (its own fit against calibration
# alone) instead. The earlier reason (0.11 dB rms at the default spread, not named) no longer holds on this plant.
# One hidden effect per kind of evidence; every effect (and half strengths, other seeds) is
# `python -m benchmarks.discrepancy 5`'s confusion table (docs/discrepancy.md): each diagnosis here
# costs ~4-8 min on a 2-core machine with the graded joint (stop 40), and the suite's budget is ~15 min.
# Stribeck has its own test. A compliant clamp (the mass at a sensor, its structural sibling, is left
# to the benchmark since stop 40), the actuator's ramps, the step-sine channel, the joint's loop:
SUITE_EFFECTS = ("clamp_compliance", "current_limit", "shaker_interaction", "micro_slip")


def assert_named_fitted_and_closed(res: dict, effect) -> None:
    """The diagnosis names ``effect`` by more than 10 BIC points, fits its strength within 30 % and
    closes its channel's gap at least threefold."""
    assert res["named_effect"] == effect.name, res["ranking"]
    assert res["ranking"][0]["delta_bic"] > 10.0
    fitted = res["fitted_parameters"][effect.name]
    assert abs(fitted / effect.parameter.default - 1.0) < 0.30, fitted
    key = {"structure": "structure_frf_db", "actuator": "actuator_nrmse", "stepsine": "stepsine_ratio_db"}[effect.channel]
    assert res["gap_before"][key] >= 3.0 * res["gap_after"][key], (res["gap_before"][key], res["gap_after"][key])


# The compliant clamp's whole diagnosis (its own structure fit, ~7 min of the suite's CPU) is `make test-slow`'s:
# the suite names the clamp by the same structure fit on FRF files (test_diagnose_frf.py,
# test_hidden_effect_is_named_from_frf_files[clamp_compliance]) and on the lap joint (test_plausible.py).
# current_limit's and shaker_interaction's whole diagnoses are too: their channel's stage is the suite's
# (test_the_actuator_stage_names_current_limit, test_the_stepsine_stage_names_the_shaker), and the
# structure stage they share with the clean campaign is test_no_effect_names_nothing_...'s.
SLOW_EFFECTS = ("micro_slip", "clamp_compliance", "current_limit", "shaker_interaction")


@pytest.mark.parametrize("effect", [pytest.param(get(e), marks=pytest.mark.slow) if e in SLOW_EFFECTS else get(e)
                                    for e in SUITE_EFFECTS], ids=lambda e: e.name)
def test_hidden_effect_is_named_fitted_and_closes_the_gap(diagnosed, effect):
    res = diagnosed(effect.name)
    assert_named_fitted_and_closed(res, effect)
    if effect.channel == "actuator":
        assert_not_confused(res, effect)


def assert_not_confused(res: dict, effect) -> None:
    """The other actuator candidates explain under a quarter of the ramps' residual (a drift is neither
    a slew nor a loop, a slew is not a loop) and stay near nominal."""
    for r in res["ranking"]:
        other = EFFECTS[r["effect"]]
        if other.channel == "actuator" and other is not effect:
            assert r["rss_reduction"] < MIN_RSS_REDUCTION, r
            span = abs(other.parameter.default - other.nominal)
            assert abs(r["fitted"][other.name] - other.nominal) < 0.05 * span, r


def stage_alone(folder, nominal: Config, channel: str) -> dict:
    """The diagnosis's stage of one channel ("actuator" or "stepsine") alone on a campaign: calibration
    alone and each candidate of that channel fitted as ``campaign.diagnose`` fits them, on that channel's
    residuals only, ranked by ``campaign.rank`` (the structure's channels, the same in every fit of this
    stage in the diagnosis, left out: BIC's penalty then counts ln n of this channel's n, a few points
    below the diagnosis's). The step-sine stage runs on the nominal structure, not on a calibrated one
    (the diagnosis's ``prepare_stepsine`` input): a harder case, whose driving-point estimate carries the
    campaign's scatter. Returns the keys of the diagnosis's result that ``assert_named_fitted_and_closed``
    and ``assert_not_confused`` read."""
    effects = [e for e in implemented() if e.channel == channel]
    with threadpool_limits(1):
        if channel == "actuator":
            act = [t for t in load_campaign(folder) if t.kind == "actuator"]
            cal = fit_actuator(nominal, act, None)
            fits = [cal] + [fit_actuator(nominal, act, e, cal) for e in effects]
            channels = [{f"actuator {k}": v for k, v in r.items()} for _, r in fits]
            cfgs = [with_actuator(nominal, th, e) for (th, _), e in zip(fits, [None] + effects)]

            def gap(cfg):
                return {"actuator_nrmse": float(np.mean([nrmse_std(t.data["F_cell"], r["F_cell"])
                                                         for t, r in zip(act, run_actuator_tests(cfg, act))]))}
        else:
            data = prepare_stepsine(nominal, load_stepsine(folder), jobs=1)
            fits = [({}, stepsine_residuals(nominal, data))]
            for e in effects:
                m, r = fit_shaker(nominal, data, e)
                fits.append(({e.name: m}, r))
            channels = [{SS_CHANNEL: r} for _, r in fits]
            cfgs = [nominal] + [e.apply(nominal, th[e.name]) for (th, _), e in zip(fits[1:], effects)]

            def gap(cfg):
                return {"stepsine_ratio_db": stepsine_gap_db(cfg, data)}
        results = [{"effect": e.name if e else None, "theta": th, "channels": ch, "score": bic(ch, len(th)), "cfg": c}
                   for e, (th, _), ch, c in zip([None] + effects, fits, channels, cfgs)]
        base, ranked, winner = rank(results)
        final = winner or base
        return {"named_effect": winner["effect"] if winner else None,
                "ranking": [{"effect": r["effect"], "delta_bic": base["score"] - r["score"],
                             "rss_reduction": r["rss_reduction"], "fitted": r["theta"]} for r in ranked],
                "fitted_parameters": final["theta"], "gap_before": gap(nominal), "gap_after": gap(final["cfg"])}


def test_the_actuator_stage_names_current_limit(short_campaigns):
    """The suite's current_limit check (the whole diagnosis is `make test-slow`'s): the actuator stage
    alone (``stage_alone``) on the seed-5 campaign with the amplifier's current limit at 0.3 A hidden
    names it as the whole diagnosis must (``assert_named_fitted_and_closed``: over NAME_THRESHOLD BIC
    points, strength within 30 %, the ramps' F_cell NRMSE closed threefold) and confuses it with no other
    actuator candidate. Measured (~8 s): current_limit 0.30000 A, dBIC 1.2e5, 100 % of the ramps' RSS;
    piezo_hysteresis dBIC 4.2, 0.3 %; preload_creep at 0."""
    effect = get("current_limit")
    res = stage_alone(short_campaigns("current_limit"), _nominal("current_limit"), "actuator")
    assert_named_fitted_and_closed(res, effect)
    assert_not_confused(res, effect)


def test_the_stepsine_stage_names_the_shaker(short_campaigns):
    """The suite's shaker_interaction check (the whole diagnosis is `make test-slow`'s): the step-sine
    stage alone (``stage_alone``) on the seed-5 campaign with the shaker's armature (0.1 kg) hidden,
    on the nominal structure, names it, fits the mass within 30 % and closes the force ratio's gap
    threefold. Measured (~35 s, the model's step-sines included): m = 0.104 kg, dBIC 259, 98.7 % of
    the ratio's RSS, gap 0.593 -> 0.069 dB over 61 lines (on the campaign's true structure 0.1002 kg,
    0.588 -> 0.020 dB over 77)."""
    effect = get("shaker_interaction")
    res = stage_alone(short_campaigns("shaker_interaction"), _nominal("shaker_interaction"), "stepsine")
    assert_named_fitted_and_closed(res, effect)


def test_micro_slip_fit_names_it_against_calibration_alone(campaigns):
    """The suite's micro_slip check (the whole diagnosis is `make test-slow`'s, SLOW_EFFECTS below): on the seed-5 campaign
    with micro_slip at its default spread (0.5) hidden, calibration alone and micro_slip's fit from it on
    the impulse tests, with the diagnosis' continuation of calibration alone from the candidate's scales
    and the refit (without the other seven candidates). micro_slip meets the naming conditions (campaign.rank:
    more than NAME_THRESHOLD BIC points over calibration alone, MIN_RSS_REDUCTION of the FRF residual), its
    spread within 30 % and the FRF gap closed threefold, as assert_named_fitted_and_closed. Measured with
    the joint start (stop 44): dBIC 4286, 36.1 % of the RSS, spread 0.522, gap 2.84 -> 0.46 dB, 80 s on a
    shared 2-core machine (stop 43, before it: dBIC 10509, 65 %, 0.515, the whole diagnosis the same).
    Without the continuation the first fit had ended at spread 0.857 (+71 %) against a poorer calibration
    (stop 43, dBIC 32536): the continuation is needed."""
    effect = get("micro_slip")
    r = fit_against_calibration_alone(campaigns, effect)
    assert r["dbic"] > NAME_THRESHOLD and r["reduction"] >= MIN_RSS_REDUCTION, r
    assert abs(r["fit"].theta["micro_slip"] / effect.parameter.default - 1.0) < 0.30, r["fit"].theta
    assert r["before"] >= 3.0 * r["after"], r


def fit_against_calibration_alone(campaigns, effect) -> dict:
    """The diagnosis's structure stage for ``effect`` alone on its campaign's impulse tests: calibration
    alone, the effect's fit from it, the continuation of calibration alone from the candidate's scales and
    the refit (without the other candidates). Returns the fits ("cal", "fit"), the FRF gaps [dB] of the
    nominal, the calibration and the fit ("before", "calibrated", "after"), the BIC difference ("dbic") and
    the fit's reduction of the FRF residual's RSS ("reduction"), as ``campaign.rank`` weighs them."""
    nominal = _nominal(effect.name)
    imp = [t for t in load_campaign(campaigns(effect.name)) if t.kind == "impulse"]
    with threadpool_limits(1):
        data = prepare(imp, nominal)
        cal = fit_structure(nominal, data, None)
        fit = fit_structure(nominal, data, effect, calibrated=cal)
        for _ in range(CONTINUE_ROUNDS):   # as the diagnosis: calibration alone continued from better scales, refitted
            better = best_nested({None: cal, effect: fit}, [effect], nominal, data)
            if better is cal:
                break
            cal = fit_structure(nominal, data, None, start=better.theta)
            if bic(fit.channels, 0) > bic(cal.channels, 0):
                fit = fit_structure(nominal, data, effect, calibrated=cal)
        before = gaps(imp, [], run_shape(nominal, data), [])["structure_frf_db"]
    rss = [sum(float(v @ v) for k, v in f.channels.items() if k.startswith("FRF")) for f in (fit, cal)]
    return {"cal": cal, "fit": fit, "before": before, "calibrated": gaps(imp, [], cal.run, [])["structure_frf_db"],
            "after": gaps(imp, [], fit.run, [])["structure_frf_db"],
            "dbic": bic(cal.channels, len(cal.theta)) - bic(fit.channels, len(fit.theta)),
            "reduction": 1.0 - rss[0] / rss[1]}


# The diagnosis's continued calibration on the rig's own form (graded default joint), seed 3, micro_slip 0.3
# hidden (issue 32 item 5; `frictionrt diagnose` with the joint start, docs/discrepancy.md "The refined whole
# form"): from it, the start at the calibration's damping and the default strength (before the joint start)
# lay above calibration alone (RSS 3187 against 2725) and the fit ended at strength 0.
OWN_FORM_CONTINUED = {"E": 1.0398, "k_t": 1.0409, "mu": 0.8978, "modal_damping": 1.0311, "dispersion": 0.0022}


@pytest.mark.slow   # ~100 s of one worker (its own campaign on the graded joint); micro_slip's check in the suite is the twin above
def test_micro_slip_at_0_6_x_is_named_from_the_calibration_that_took_its_damping(tmp_path):
    """micro_slip at 0.6 x its default spread (0.3) on the rig's own form, seed 3: calibration alone
    from the diagnosis's continued point (damping x 1.03 for the truth's 0.94: it took the effect's
    friction damping), then micro_slip's fit from it (``joint_start``: damping and spread together).
    Named by the diagnosis's conditions (more than NAME_THRESHOLD BIC points, MIN_RSS_REDUCTION of the
    FRF residual), the damping back within 10 % of the truth's (0.943), the spread within 50 % of 0.3
    (the valley a fit can follow is flat from 0.25 to 0.4 within RSS 1000-1400: docs/discrepancy.md).
    Measured (stop 44, loaded 2-core machine, 106 s): calibration RSS 2673, the fit 0.399 (+33 %),
    damping 0.900, dBIC 5953, 42.9 %; the whole diagnosis names it at 0.384, dBIC 3187, 27.3 %."""
    nominal = with_sets(Config(), [])
    effect = get("micro_slip")
    folder = make_campaign(tmp_path / "c", "micro_slip", strength=0.3, seed=3, cfg=nominal)[0].parent
    with threadpool_limits(1):
        data = prepare([t for t in load_campaign(folder) if t.kind == "impulse"], nominal)
        cal = fit_structure(nominal, data, None, start=OWN_FORM_CONTINUED)
        fit = fit_structure(nominal, data, effect, calibrated=cal)
    dbic = bic(cal.channels, len(cal.theta)) - bic(fit.channels, len(fit.theta))
    rss = [sum(float(v @ v) for v in f.channels.values()) for f in (fit, cal)]
    assert dbic > NAME_THRESHOLD and 1.0 - rss[0] / rss[1] >= MIN_RSS_REDUCTION, (dbic, rss, fit.theta)
    true_damping = scatter_sets(np.random.default_rng(3))["modal_damping"]   # 0.943
    assert abs(fit.theta["modal_damping"] / true_damping - 1.0) < 0.10, fit.theta
    assert abs(fit.theta["micro_slip"] / 0.3 - 1.0) < 0.5, fit.theta


def test_suite_effects_cover_every_kind_of_evidence():
    assert set(SUITE_EFFECTS) | {"stribeck"} <= {e.name for e in implemented()}
    assert {get(e).channel for e in SUITE_EFFECTS} == {e.channel for e in implemented()}


def test_stribeck_fit_names_it_and_calibration_alone_cannot_make_it(campaigns):
    """The suite's Stribeck check (the whole diagnosis below is `make test-slow`'s): on the seed-5 campaign
    with Stribeck friction hidden, its fit against calibration alone (``fit_against_calibration_alone``)
    meets the naming conditions, fits its strength within 30 % and closes the FRF gap threefold; and
    calibration alone (mu free within a factor 2) leaves at least twice the effect's gap and at least
    half a dB (the bounds of the whole diagnosis's test below, for the same reason)."""
    effect = get("stribeck")
    r = fit_against_calibration_alone(campaigns, effect)
    assert r["dbic"] > NAME_THRESHOLD and r["reduction"] >= MIN_RSS_REDUCTION, r
    assert abs(r["fit"].theta["stribeck"] / effect.parameter.default - 1.0) < 0.30, r["fit"].theta
    assert r["before"] >= 3.0 * r["after"], r
    assert r["calibrated"] >= 2.0 * r["after"] and r["calibrated"] >= 0.5, r


@pytest.mark.slow   # ~5 min of the suite's CPU; its structure stage is the test above
def test_stribeck_is_named_and_is_not_a_friction_coefficient_change(diagnosed):
    """Named, fitted and closed as the other effects (test_hidden_effect_is_named_fitted_and_closes_the_gap);
    and calibration alone (mu free within a factor 2) cannot make Stribeck friction: the pairs break away
    at mu_s but slide at mu_k, so a higher mu that matches the joint modes' shift leaves their
    damping too low. Measured on seed 5, FRF gap nominal / calibrated / with stribeck [dB]: AMD
    EPYC (Zen 5) 3.06 / 1.31 / 0.16, Intel Xeon 3.06 / 0.95 / 0.37 (the design's BLAS kernels
    differ by CPU and the joint's slip amplifies last bits). The bound: calibration leaves at least
    twice the effect's gap and at least half a dB (the scatter of one impulse FRF's gap between the
    two machines is ~0.4 dB); the fit returns the campaign's own mu scatter (0.9315 for 0.9338)."""
    res = diagnosed("stribeck")
    assert_named_fitted_and_closed(res, get("stribeck"))
    calibrated, after = res["gap_calibrated"]["structure_frf_db"], res["gap_after"]["structure_frf_db"]
    assert calibrated >= 2.0 * after and calibrated >= 0.5, (calibrated, after)
    true_mu = scatter_sets(np.random.default_rng(SEED))["mu"]
    assert res["fitted_parameters"]["mu"] == pytest.approx(true_mu, rel=0.03)


def test_true_parameters_fit_the_frfs_at_noise_level(campaigns):
    """The structure fit's residuals, (ln|H_meas| - ln|H_model|) / sigma_k, are O(1) for the campaign's
    true (scattered) parameters: the noise model and the model chain are right, also in the 40 and
    100 N tests that slip (identified as such: their mode 3 lies ~6 % below the stuck model's)."""
    nominal = _nominal("none")
    true = scaled(nominal, scatter_sets(np.random.default_rng(SEED)))   # make_campaign's first draws
    data = prepare([t for t in load_campaign(campaigns("none")) if t.kind == "impulse"], nominal)
    assert [round(d.F_N1) for d in data] == [40, 100, 300] and [d.stuck for d in data] == [False, False, True]
    assert all(d.sel[s].sum() > 1400 for d in data for s in SENSORS)       # of 1597 bins in 4-1600 Hz
    rms = {s: float(np.sqrt(np.mean(r ** 2))) for s, r in run_shape(true, data).r.items()}
    rms_nominal = {s: float(np.sqrt(np.mean(r ** 2))) for s, r in run_shape(nominal, data).r.items()}
    assert all(v < 1.0 for v in rms.values()), rms
    assert all(v > 5.0 for v in rms_nominal.values()), rms_nominal   # scatter alone: far outside the noise


@pytest.mark.slow   # the whole clean diagnosis, ~300 s of one worker; the suite's twin is the FRF files' (test_diagnose_frf.py)
def test_no_effect_names_nothing(campaigns, capsys):
    assert main(["--set", UNIFORM, "diagnose", str(campaigns("none")), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["named_effect"] is None, res["ranking"]
    # the best candidate explains little and at a negligible strength, i.e. within 5 % of the way from
    # its nominal (no effect) to its default strength (seed 5 on the graded joint, AMD EPYC, stop 40:
    # stribeck s = 0.0077, 2.6 % of its default, 0.9 % of the RSS, dBIC 76, after calibration alone was
    # continued and the candidates refitted from it; before the refit, from a calibration in another
    # valley, 0.0089 with 22.7 % of the RSS; on the 10 mm joint, AMD EPYC:
    # accelerometer_mass 3.4e-5 kg, 0.2 % of its default, 7.4 % of the RSS, dBIC 897: BIC counts the
    # correlated FRF bins as independent, so a tiny real improvement scores high; Intel Xeon:
    # current_limit 0.99982 A against its nominal 1 A, 0.03 % of the way to 0.3 A; with the far
    # calibration and the quasi-static step of docs/plant.md 2.6, Intel Xeon: stribeck s = 0.0033,
    # 1.1 % of its default 0.3, 5.8 % of the RSS, dBIC 458)
    top = res["ranking"][0]
    effect = EFFECTS[top["effect"]]
    assert top["rss_reduction"] < 0.25
    assert abs(top["fitted"][effect.name] - effect.nominal) < 0.05 * abs(effect.parameter.default - effect.nominal), top


def at_nominal_fits(nominal, data, effect, **kwargs):
    """A stand-in for ``fit_structure`` that returns the nominal scales at once (the report's tests: what
    the diagnosis writes, not what it fits)."""
    from frictionrt.rt.discrepancy.diagnose.structure import StructureFit, struct_cfg
    th = {"E": 1.0, "k_t": 1.0, "mu": 1.0, "modal_damping": 1.0, "dispersion": 0.0} | (
        {effect.name: effect.parameter.default} if effect else {})
    run = run_shape(nominal, data)
    return StructureFit(th, {f"FRF {s}": v for s, v in run.r.items()}, run, struct_cfg(nominal, th, effect), {})


def test_the_report_folder_is_complete(tmp_path, capsys, monkeypatch):
    """``diagnose --out`` on a short clean campaign (0.3 s impulse tests), the structure fits stood in
    for by the nominal scales (``at_nominal_fits``; the whole diagnosis is test_no_effect_names_nothing's):
    diagnose.json as printed, model.toml, report.md, the rrd and a plot per test; the rrd holds per impulse
    test the gap measured - model [dB] on the frequency timeline, whose rms over the bins is the report's
    FRF gap (same windows, same band), one blueprint, the report as a document."""
    from rerun.chunk import RrdReader
    nominal = _nominal("none")
    folder = make_campaign(tmp_path / "c", "none", seed=SEED, record_s=0.3, cfg=nominal)[0].parent
    monkeypatch.setattr(campaign_module, "fit_structure", at_nominal_fits)
    out = tmp_path / "report"
    assert main(["--set", UNIFORM, "diagnose", str(folder), "--jobs", "1", "--json", "--out", str(out)]) == 0
    res = json.loads(capsys.readouterr().out)
    assert json.loads((out / "diagnose.json").read_text()) == res
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["diagnose.json", "model.toml", "report.md", "diagnosis.rrd"]
        + [f"frf_impulse_0{j}.png" for j in (1, 2, 3)] + [f"actuator_actuator_0{j}.png" for j in (1, 2, 3)])
    reader = RrdReader(out / "diagnosis.rrd")
    assert len(reader.blueprints()) == 1
    gap = {}
    for c in reader.stream().to_chunks():
        if c.entity_path.startswith("/frf_gap/impulse_01/"):
            gap[c.entity_path.rsplit("/", 1)[1]] = c.to_record_batch().column("Scalars:scalars").flatten().to_numpy()
    for k, key in (("before", "gap_before"), ("after", "gap_after")):
        assert np.sqrt(np.mean(gap[k] ** 2)) == pytest.approx(res[key]["impulse_01"]["frf_db"], abs=1e-4)
    assert any(c.entity_path == "/report" and c.is_static for c in reader.stream().to_chunks())


def _records(path):
    with open(path, "rb") as f:
        return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}


def test_files_validate_and_do_not_reveal_the_effect(short_campaigns):
    clean, hidden = short_campaigns("none"), short_campaigns("clamp_compliance")
    files = sorted(p.name for p in clean.glob("*.mcap"))
    assert files == sorted(p.name for p in hidden.glob("*.mcap")) and len(files) == 6
    for name in files:
        assert validate(hidden / name) == [], name
        # same seed: the same hammer hits and descriptions; the records are identical but for the time each
        # file was written (its UTC start), no config stored
        a, b = _records(clean / name), _records(hidden / name)
        for r in (a, b):
            assert set(r["frictionrt"]) == {"start_utc"}
            start = {"start_utc": r["frictionrt"].pop("start_utc")}
            assert int(r["signals"].pop("start_ns")) == start_time_ns(start) > 0
        assert a == b
    text = b"".join((hidden / n).read_bytes() for n in files)
    assert b"clamp" not in text and b"compliance" not in text


def test_bad_input_exits_2_with_one_line(tmp_path, capsys):
    assert main(["rig", "--effect", "shaker_interaction", "-o", str(tmp_path / "x")]) == 2
    assert main(["rig", "--effect", "nonsense", "-o", str(tmp_path / "x")]) == 2
    assert main(["rig", "--effect", "current_limit", "--strength", "5", "-o", str(tmp_path / "x")]) == 2
    assert main(["diagnose", str(tmp_path)]) == 2                  # no *.mcap in it
    (tmp_path / "junk.mcap").write_bytes(b"not mcap")
    assert main(["diagnose", str(tmp_path)]) == 2
    assert main(["rig", "--effect", "none", "--frf-files", "--stepsine", "-o", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 6 and all(line.startswith("frictionrt: error:") for line in err)
    assert "add --stepsine" in err[0] and "apply to the time-series campaign only" in err[5]
    assert not (tmp_path / "x").exists()


def test_list_json_shows_every_effect(capsys):
    assert main(["rig", "--list", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["effects"]
    names = {r["name"]: r for r in rows}
    assert set(names) >= {"accelerometer_mass", "clamp_compliance", "moving_mass", "current_limit", "stribeck",
                          "piezo_hysteresis", "preload_creep", "micro_slip", "shaker_interaction"}
    assert all(r["implemented"] for r in rows) and names["current_limit"]["default_strength"] == 0.3


def test_stepsine_files_read_back_and_do_not_reveal_the_shaker(short_campaigns):
    """rig --stepsine: six FRF files (2 amplitudes x 3 F_N1 levels) with measured force and drive
    amplitudes, readable by rt.log.frf_files; the shaker shows only as F_amp_N != drive_amp_N."""
    from frictionrt.rt.log.frf_files import load_frf_folder
    folder = short_campaigns("shaker_interaction")
    tests = load_frf_folder(folder)
    assert len(tests) == 6 and all(t.meta["kind"] == "stepsine" and len(t.freq_hz) >= 10 for t in tests)
    assert sorted(round(t.F_N1) for t in tests) == [40, 40, 100, 100, 300, 300]
    ratio = np.concatenate([t.F_amp_N / t.drive_amp for t in tests])
    assert ratio.min() < 0.8 and ratio.max() > 1.2          # drop-out and rise around the resonances
    text = b"".join(p.read_bytes() for p in folder.iterdir() if p.suffix in (".csv", ".json"))
    assert b"shaker" not in text and b"armature" not in text and b"mass" not in text


def test_parallel_fits_give_the_serial_result(tmp_path, capsys):
    """diagnose's candidate fits in worker processes (rt.discrepancy.diagnose.fit_in_parallel, diagnose --jobs)
    and on a dask cluster (diagnose --dask) give the serial result to the bit: each fit is a pure
    function of its inputs. Two actuator candidates of a short clean campaign (the structural fits
    go through the same function; the model step-sines through run_branches, tests/test_stepsine.py)."""
    from distributed import LocalCluster
    folder = make_campaign(tmp_path / "c", "none", seed=SEED, record_s=0.3)[0].parent
    act = [t for t in load_campaign(folder) if t.kind == "actuator"]
    nominal = with_sets(Config(), [])
    cal = fit_actuator(nominal, act, None)
    calls = [(fit_actuator, (nominal, act, get(n), cal), {}) for n in ("current_limit", "preload_creep")]
    serial = fit_in_parallel(calls, 1)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as cluster:
        on_dask = fit_in_parallel(calls, None, cluster.scheduler_address)
    for other in (fit_in_parallel(calls, 2), on_dask):
        for (th1, r1), (th2, r2) in zip(serial, other):
            assert th1 == th2 and all(np.array_equal(r1[k], r2[k]) for k in r1)
    assert main(["diagnose", str(folder), "--jobs", "0"]) == 2
    assert main(["diagnose", str(folder), "--dask", "tcp://127.0.0.1:9"]) == 2   # before any fit runs
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "no dask scheduler" in err[1]


def test_an_interrupted_diagnosis_keeps_its_fits(tmp_path, capsys, monkeypatch):
    """Ctrl-C in the second structural candidate's fit (the structure fits patched: the nominal scales at once,
    then KeyboardInterrupt): exit 130, the report folder holds calibration alone (with the actuator's c_v)
    and the first candidate (diagnose.json as printed, model.toml the candidate's configuration), the
    candidates' progress bar and the wall time on stderr, no traceback."""
    from frictionrt.rt.common.config import load
    nominal = _nominal("none")
    folder = make_campaign(tmp_path / "c", "none", seed=SEED, record_s=0.3, cfg=nominal)[0].parent
    struct_eff = [e for e in implemented() if e.channel == "structure"]

    def at_nominal(nominal, data, effect, **kwargs):
        if effect is not None and effect is not struct_eff[0]:
            raise KeyboardInterrupt
        return at_nominal_fits(nominal, data, effect)
    monkeypatch.setattr(campaign_module, "fit_structure", at_nominal)
    out = tmp_path / "report"
    assert main(["--set", UNIFORM, "diagnose", str(folder), "--jobs", "1", "--json", "--out", str(out)]) == 130
    printed, err = capsys.readouterr()
    res = json.loads(printed)
    first = struct_eff[0]
    assert res["interrupted"] and res["input"] == "campaign" and list(res["fits"]) == ["calibration only", first.name]
    assert "c_v" in res["fits"]["calibration only"]["fitted"]
    assert sorted(f.name for f in out.iterdir()) == ["diagnose.json", "model.toml", "report.md"]
    assert json.loads((out / "diagnose.json").read_text()) == res
    assert load(out / "model.toml") == first.apply(nominal, first.parameter.default)
    assert "candidates' fits: " in err and "the 2 fits done so far are in" in err
    assert "Traceback" not in err and err.rstrip().splitlines()[-1].endswith(" s wall")
