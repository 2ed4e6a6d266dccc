"""rt.experiments.mechanisms' pure parts: which cells make C3 and C4 fail (rt.experiments.claims'
rules on a report's numbers), and the constant clamp's peak at a law's mean force. The closed-loop
re-runs themselves are measured in docs/experiments.md, "Why each failing claim fails"."""
import pytest

from frictionrt.rt.experiments.mechanisms import constant_clamp_peak, failing_cells
from frictionrt.rt.experiments.claims import claim_c3, claim_c4
from frictionrt.rt.experiments.reproduce_report import jsonable


def _view(reduction: dict) -> dict:
    """One estimator's report part, as report.json has it (text keys), from reductions law -> mode -> amp."""
    return jsonable({"peak_change_db": reduction,
                     "claims": {"C3": claim_c3(reduction), "C4": claim_c4(reduction)}})


def test_the_cells_that_fail_c3_and_c4_are_listed_and_no_others():
    # each law reduces mode 3 only: mode 4 at 5 N is within 0.5 dB (hysteresis) or 2.6 dB above passive
    # (Lyapunov), so C3 fails on both laws' mode-4 cell at 5 N, and C4 on Lyapunov's
    reduction = {"hysteresis": {3: {5.0: -5.1, 20.0: -9.5}, 4: {5.0: -0.2, 20.0: -7.7}},
                 "lyapunov": {3: {5.0: -9.7, 20.0: -12.3}, 4: {5.0: +2.6, 20.0: -9.2}}}
    cells = failing_cells({"oracle": _view(reduction)})
    got = {(c["claim"], c["law"], c["mode"], c["amp"]) for c in cells}
    assert got == {("C3", "hysteresis", "4", "5"), ("C3", "lyapunov", "4", "5"), ("C4", "lyapunov", "4", "5")}
    assert all(c["estimator"] == "oracle" for c in cells)


def test_claims_that_hold_give_no_cells():
    reduction = {"hysteresis": {3: {5.0: -5.1, 20.0: -9.5}, 4: {5.0: -0.9, 20.0: -7.7}},
                 "lyapunov": {3: {5.0: -9.7, 20.0: -12.3}, 4: {5.0: -7.3, 20.0: -9.2}}}
    assert failing_cells({"observer": _view(reduction)}) == []


def test_constant_clamp_peak_is_linear_between_the_forces_tried():
    peaks = {"40": 50.9, "80": 48.9, "160": 68.4, "320": 83.5, "600": 103.0}   # mode 5, 5 N (docs/experiments.md)
    assert constant_clamp_peak(peaks, 160.0) == 68.4
    assert constant_clamp_peak(peaks, 240.0) == pytest.approx(0.5 * (68.4 + 83.5))
    assert constant_clamp_peak(peaks, 700.0) == 103.0   # held at the last force beyond the range
