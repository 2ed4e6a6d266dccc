"""The observer model's softened normal springs selected by configuration (``observer.spring_scale``,
rt/common/config.py; observer/model.py): ``simulate --set observer.spring_scale=0.1`` designs the
loop's observer on the softened model and records the field in the log's configuration; ``replay``
of that log is bit-exact, and the C exported from it (``export-c --from-log``) replays it bit for
bit; a bad value is refused in one line, exit 2. One log of 0.01 s (210 ticks) and one export keep
it short."""
import json

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.export.cbuild import OUTPUTS
from frictionrt.rt.log.mcap_log import read_mcap

SCALE = 0.1
TICKS = 210


@pytest.fixture(scope="module")
def soft(tmp_path_factory):
    """(log, export dir): the hysteresis law on the paper's observer with its springs at SCALE, mode
    4's passive peak, 10 N, 0.01 s; and the C that ``export-c --from-log`` writes from that log."""
    d = tmp_path_factory.mktemp("observer_spring_config")
    assert main(["simulate", "--law", "hysteresis", "--freq", "370.2", "--amp", "10", "--duration", "0.01",
                 "--set", f"observer.spring_scale={SCALE}", "--out", str(d / "soft"), "--no-rrd", "--json"]) == 0
    log = d / "soft.mcap"
    assert main(["export-c", "--from-log", str(log), "-o", str(d / "c"), "--json"]) == 0
    return log, d / "c"


def _last_json(capsys) -> dict:
    return json.loads(capsys.readouterr().out.splitlines()[-1])


def test_the_log_records_the_scale_and_its_design_is_the_softened_models(soft):
    from frictionrt.observer.kalman import design_observer
    from frictionrt.rt.export.replay_c import log_design
    from frictionrt.rt.common.config import load
    log, _ = soft
    rec = read_mcap(log)
    cfg_text = rec.metadata["config"]
    assert "spring_scale" in cfg_text
    _, _, _, loop, _, report = log_design(log)
    assert loop.cfg.observer.spring_scale == SCALE
    assert report["source"] == "log" and report["rebuilt_identical"] is True
    # the loop ran the softened design: its gain is design_observer at SCALE, not the paper's model
    default = load()
    softened = design_observer(default, loop.plant, SCALE).params
    paper = design_observer(default, loop.plant).params
    assert loop.observer.M.tobytes() == softened.M.tobytes()
    assert loop.observer.A_d.tobytes() == softened.A_d.tobytes()
    assert not np.allclose(loop.observer.A_d, paper.A_d, rtol=1e-3, atol=0.0)   # not vacuous: the models differ


def test_replay_of_a_softened_log_is_bit_exact(soft, capsys):
    capsys.readouterr()
    code = main(["replay", str(soft[0]), "--json"])
    r = _last_json(capsys)
    assert code == 0 and r["bit_exact"] is True and r["ticks"] == TICKS and r["estimator"] == "observer"


def test_the_c_exported_from_a_softened_log_replays_it_bit_for_bit(soft, capsys):
    log, exp = soft
    capsys.readouterr()
    code = main(["replay", str(log), "--c", str(exp), "--json"])
    r = _last_json(capsys)
    assert code == 0 and r["bit_exact"] is True and r["ticks"] == TICKS and r["first_mismatch_tick"] is None
    assert r["signals_compared"] == list(OUTPUTS)
    assert r["design_hash"] == r["log_design_hash"] == read_mcap(log).metadata["controller_design"]
    rec = read_mcap(log)   # not vacuous: the estimate moved (u_rel_hat beyond 0.1 um)
    assert np.abs(rec.log[:, rec.column("u_rel_hat")]).max() > 1e-7


@pytest.mark.parametrize("value", ["0", "-0.5", "nan", "inf", "1.5"])
def test_a_bad_scale_is_refused_in_one_line(value, tmp_path, capsys):
    code = main(["export-c", "--set", f"observer.spring_scale={value}", "-o", str(tmp_path / "c")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert "observer.spring_scale" in err[0] and "0 < value <= 1" in err[0]
    assert not (tmp_path / "c").exists()


def test_an_imported_structure_refuses_a_scale_in_one_line():
    """The softened springs are the built-in beams' model: the superelement's model names the key."""
    from frictionrt.observer.model import build_observer_model
    from frictionrt.plant.se_plant import SEPlant
    from frictionrt.rt.common.config import load, with_sets
    cfg = with_sets(load(), [f"observer.spring_scale={SCALE}"])
    fake = SEPlant.__new__(SEPlant)   # the check comes before any use of the plant
    with pytest.raises(ValueError, match=r"^observer.spring_scale = 0.1: .* use observer.spring_scale=1"):
        build_observer_model(cfg, fake)


def test_frictionrt_observer_reports_the_scale_and_the_softened_modes(capsys):
    """``frictionrt observer --set observer.spring_scale=0.1``: the design's modes are the softened
    model's (mode 4 moves below the paper model's by more than 1 %: 380.7 -> 375.2 Hz) and the scale is
    reported."""
    from frictionrt.observer.model import build_observer_model
    from frictionrt.rt.common.config import load
    capsys.readouterr()
    assert main(["observer", "--set", f"observer.spring_scale={SCALE}", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["spring_scale"] == SCALE
    soft = build_observer_model(load(), None, SCALE).modes_hz
    assert np.array_equal(np.array(d["modes_hz"]), soft)
    assert d["modes_hz"][3] < 0.99 * build_observer_model(load()).modes_hz[3]
