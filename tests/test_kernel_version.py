"""The kernel version a log records, and what a replay of an older log says about it."""
from frictionrt.rt.common import kernel_version as kv
from frictionrt.rt.log.design_record import environment_changes
from frictionrt.rt.log.writer import run_metadata


def test_every_version_after_the_first_says_what_changed():
    assert set(kv.CHANGES) == set(range(2, kv.KERNEL_VERSION + 1))
    assert all(len(text) > 20 for text in kv.CHANGES.values())


def test_a_log_records_this_version(cfg):
    meta = run_metadata(cfg, "passive", "oracle", 1, 200.0, 5.0, 0.1, False, argv=["x"])
    assert kv.logged_version(meta) == kv.KERNEL_VERSION


def test_an_older_log_names_the_changes_since(monkeypatch):
    monkeypatch.setattr(kv, "KERNEL_VERSION", 3)
    monkeypatch.setattr(kv, "CHANGES", {2: "the observer's Newton stops on convergence",
                                        3: "the plant step's scheme"})
    assert kv.changes_since(3) == []
    assert kv.changes_since(1) == kv.changes_since(0) == ["v2: the observer's Newton stops on convergence",
                                                          "v3: the plant step's scheme"]
    assert kv.changes_since(2) == ["v3: the plant step's scheme"]
    lines = [line for line in environment_changes({"kernel_version": "2"}) if line.startswith("kernel version")]
    assert lines == ["kernel version 2 -> 3 (v3: the plant step's scheme)"]


def test_this_version_reports_no_change():
    assert not [line for line in environment_changes({"kernel_version": str(kv.KERNEL_VERSION)})
                if line.startswith("kernel version")]
