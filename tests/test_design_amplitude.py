"""The amplitude-following observer's tables in the log's design record (rt/log/design_record.py):
``simulate --out`` stores them as params.amplitude.*, ``replay`` and ``export-c --from-log`` (both
through ``use_logged``) put the stored bits into the loop they rebuild, a loop of the paper's
observer stores none (its logs' bytes unchanged), and a log without them (written before they were
stored) rebuilds them from its configuration and says so. One log of 0.01 s (210 ticks) and one
rebuild of its loop; the stored design is then altered by one ulp in memory (the attachment read is
replaced), so the tests tell the stored bits from this machine's rebuild."""
import dataclasses

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.log import design_record as dr
from frictionrt.rt.log.mcap_log import read_attachment

AMP_KEYS = {f"params.amplitude.{k}" for k in ("grid", "blocks", "scale", "inv_omega", "k_j")}


@pytest.fixture(scope="module")
def amp(tmp_path_factory):
    """(log, its stored design arrays, loop, state, report): the hysteresis law on the amplitude
    kind at mode 4's passive peak, 10 N, 0.01 s; the loop and state ``export-c --from-log`` and
    ``replay --c`` rebuild from it (``log_design``) and that rebuild's design report."""
    from frictionrt.rt.export.replay_c import log_design
    d = tmp_path_factory.mktemp("design_amplitude")
    assert main(["simulate", "--law", "hysteresis", "--estimator", "amplitude", "--freq", "370.2", "--amp", "10",
                 "--duration", "0.01", "--out", str(d / "amp"), "--no-rrd", "--json"]) == 0
    log = d / "amp.mcap"
    _, _, _, loop, st, report = log_design(log)
    return log, dr.from_npz(read_attachment(log, dr.DESIGN_ATTACHMENT)), loop, st, report


def _use(amp, monkeypatch, arrays, loop=None):
    """(loop, report) of ``use_logged`` on amp's log with ``arrays`` as its stored design."""
    monkeypatch.setattr("frictionrt.rt.log.mcap_log.read_attachment", lambda path, name: dr.to_npz(arrays))
    out_loop, _, report = dr.use_logged(amp[0], amp[2] if loop is None else loop, amp[3])
    return out_loop, report


def test_the_amplitude_kind_stores_its_tables_and_a_papers_observer_loop_none(amp):
    _, stored, loop, st, report = amp
    assert AMP_KEYS <= set(stored)
    assert stored["params.amplitude.blocks"].shape == (7, 11, 7) and stored["params.amplitude.grid"][0] == 0.0
    assert stored["params.amplitude.k_j"].shape == () and float(stored["params.amplitude.k_j"]) == 0.0
    assert report["source"] == "log" and report["rebuilt_identical"] is True   # what replay reports
    assert report["why"] == "the design arrays the run used, from the log"
    for name, a in loop.amplitude._asdict().items():
        assert np.asarray(a).tobytes() == stored[f"params.amplitude.{name}"].tobytes()
    from frictionrt.observer.amplitude import no_amplitude
    paper = dataclasses.replace(loop, estimator="observer", amplitude=no_amplitude())
    assert not dr.runs(paper, "amplitude") and dr.runs(loop, "amplitude")
    assert set(dr.design_arrays(paper, st)) == set(stored) - AMP_KEYS


def test_the_stored_tables_not_this_machines_rebuild_go_into_the_loop_and_the_export(amp, monkeypatch):
    """Stored blocks one ulp above this machine's: the loop (and so the export's P_AMPLITUDE and its
    design hash) carries the stored bits, and the report names the table that differs."""
    from frictionrt.rt.export.record import controller_record
    arrays = dict(amp[1])
    arrays["params.amplitude.blocks"] = np.nextafter(arrays["params.amplitude.blocks"], np.inf)
    loop, report = _use(amp, monkeypatch, arrays)
    assert loop.amplitude.blocks.tobytes() == arrays["params.amplitude.blocks"].tobytes()
    assert loop.amplitude.blocks.tobytes() != amp[2].amplitude.blocks.tobytes()
    assert not loop.amplitude.blocks.flags.writeable
    assert report["source"] == "log" and report["rebuilt_identical"] is False
    assert report["worst"] == "params.amplitude.blocks" and 0 < report["max_rel_diff"] < 1e-15
    rec = controller_record(loop, amp[3])
    assert rec["amplitude.blocks"].tobytes() == arrays["params.amplitude.blocks"].tobytes()


def test_a_log_without_the_tables_rebuilds_them_and_says_so(amp, monkeypatch):
    """A log written before the tables were stored: the other parts still come from the log (the
    observer's gain one ulp off shows it), the tables are this machine's, and "why" says so."""
    arrays = {k: v for k, v in amp[1].items() if k not in AMP_KEYS}
    arrays["params.observer.M"] = np.nextafter(arrays["params.observer.M"], np.inf)
    loop, report = _use(amp, monkeypatch, arrays)
    assert loop.observer.M.tobytes() == arrays["params.observer.M"].tobytes()
    assert loop.amplitude is amp[2].amplitude   # rebuilt here, left as built
    assert report["source"] == "log" and report["worst"] == "params.observer.M"
    assert "carries no amplitude tables" in report["why"] and "rebuilt here" in report["why"]
    assert dr.rebuilt_parts(loop, arrays) == ["amplitude"] and dr.rebuilt_parts(loop, amp[1]) == []
    assert dr.rebuilt_parts(loop, arrays, parts=("plant", "actuator")) == []   # replay --plant


def test_a_papers_observer_log_reports_as_before(amp, monkeypatch):
    from frictionrt.observer.amplitude import no_amplitude
    paper = dataclasses.replace(amp[2], estimator="observer", amplitude=no_amplitude())
    arrays = {k: v for k, v in amp[1].items() if k not in AMP_KEYS}
    loop, report = _use(amp, monkeypatch, arrays, loop=paper)
    assert len(loop.amplitude.grid) == 0
    assert (report["source"], report["why"], report["rebuilt_identical"]) == (
        "log", "the design arrays the run used, from the log", True)
