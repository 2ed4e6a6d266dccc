"""Calibration from far away in the time-series workflow (issue 18, item 3): the impulse tests'
calibration (rt.discrepancy.diagnose.structure.fit_structure) moves the contact stiffness and the
modal damping on log scales over CAL_FAR's decades, so a nominal model whose k_t is several times
off is calibrated, not left on a bound."""
import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.chain import scaled
from frictionrt.rt.discrepancy.diagnose import load_campaign
from frictionrt.rt.discrepancy.diagnose.structure import CAL_FAR, fit_structure, prepare, run_shape
from frictionrt.rt.discrepancy.rig import make_campaign, scatter_sets

SEED = 3
K_T_OFF = 0.2        # the truth's k_t against the nominal's: below the former bound 0.6


@pytest.fixture(scope="module")
def far_fit(tmp_path_factory, shared_results):
    """A campaign whose structure has k_t x 0.2 (and the seed's scatter), calibrated from the default
    nominal; BLAS single-threaded, as in diagnose (the fit 20 s on a shared 2-core machine). Returns
    (the fitted parameters, the weighted residual rms of the fit and of the nominal), computed once
    per run for both xdist workers (conftest's ``shared_results``: the two tests here may land on
    different workers)."""
    def compute():
        nominal = with_sets(Config(), [])
        folder = make_campaign(tmp_path_factory.mktemp("far") / "c", "none", seed=SEED,
                               cfg=scaled(nominal, {"k_t": K_T_OFF}), ramps_s=())[0].parent
        with threadpool_limits(1):
            data = prepare([t for t in load_campaign(folder) if t.kind == "impulse"], nominal)
            fit = fit_structure(nominal, data, None)
            r0 = np.concatenate(list(run_shape(nominal, data).r.values()))
        r = np.concatenate(list(fit.channels.values()))
        return dict(fit.theta), float(np.sqrt(np.mean(r ** 2))), float(np.sqrt(np.mean(r0 ** 2)))
    return shared_results(("far_fit", SEED, K_T_OFF), compute)


def test_a_far_off_contact_stiffness_is_recovered(far_fit):
    """From the nominal, 5x off in k_t, the calibration moves k_t by a factor 4.5 to the truth and E to
    its scatter. Measured on the converged plant (issue 32): k_t 0.2227 for 0.2042 (+9.1 %), E 1.0411 for
    1.04, weighted residual rms 3.57 against the nominal's 28. The k_t tolerance is the calibration's own
    error on this campaign, not the far start's: started at the true k_t x 0.2 (near) the same fit ends at
    +10.6 % (rms 4.43); so 15 %. (On the earlier per-pair plant: 0.2034 for 0.2042, rms 0.52.)"""
    theta, rms, rms_nominal = far_fit
    true = scatter_sets(np.random.default_rng(SEED))
    assert CAL_FAR["k_t"][0] < 2 * K_T_OFF
    assert theta["k_t"] == pytest.approx(K_T_OFF * true["k_t"], rel=0.15), theta
    assert theta["E"] == pytest.approx(true["E"], rel=0.01), theta
    assert rms < 0.2 * rms_nominal, (rms, rms_nominal)


@pytest.mark.xfail(strict=True, reason="issue 32, measured on the converged plant: the calibration stops at a "
                   "weighted residual rms of 3.57 (modal damping 1.77x for the true 0.94, dispersion -0.081), the "
                   "truth's parameters give 0.29 on the same files; from a near start (k_t x 0.2 told) it stops "
                   "at 4.43 (damping 2.53x): a poor optimum of the rough cost from either start (docs/discrepancy.md "
                   "'What remains'), not the far start's")
def test_the_far_calibration_reaches_the_noise(far_fit):
    """The calibrated FRF residuals at the noise's level (weighted rms < 1; the truth's own 0.29)."""
    assert far_fit[1] < 1.0, far_fit
