"""How a benchmark writes its --json record (benchmarks/entry.py ``write_json``): whole or not at all."""
import json

import pytest

from benchmarks.entry import write_json


def test_write_json_writes_the_whole_record_and_nothing_without_a_path(tmp_path, monkeypatch):
    """The record reads back equal, no temporary file stays beside it; no path writes nothing; a
    record that cannot be serialised leaves the earlier file as it was."""
    out = tmp_path / "rec.json"
    write_json(out, {"a": [1, 2.5], "b": "x"})
    assert json.loads(out.read_text()) == {"a": [1, 2.5], "b": "x"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec.json"]
    monkeypatch.chdir(tmp_path)
    write_json(None, {"a": 1})
    write_json("", {"a": 1})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec.json"]
    with pytest.raises(TypeError):
        write_json(out, {"a": object()})
    assert json.loads(out.read_text()) == {"a": [1, 2.5], "b": "x"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec.json"]
