"""The typed configuration: SPEC defaults, overrides, validation messages, round trip."""
import math
import tomllib

import pytest

from rt.common.config import ConfigError, dumps, load, to_dict


def test_defaults_are_the_spec_values():
    cfg = load()
    beams = {b.name: b for b in cfg.plant.beams}
    main, damper = beams["main"], beams["damper"]
    assert (main.length_m, main.width_m, main.height_m) == (0.775, 0.040, 0.008)
    assert (damper.length_m, damper.x0_m, damper.x0_m + damper.length_m) == (0.160, 0.465, 0.625)
    assert (main.E, main.rho, main.nu) == (210e9, 7850.0, 0.3)
    screws = {s.name: s for s in cfg.plant.screws}
    assert screws["normal"].F_N == 6000.0 and screws["normal"].x_m == pytest.approx(0.475)
    assert screws["adaptive"].adaptive and screws["adaptive"].x_m == pytest.approx(0.615)
    assert (cfg.tracking.F_min_N, cfg.tracking.F_max_N) == (40.0, 600.0)
    assert cfg.plant.interface.mu == 0.4 and cfg.plant.interface.pitch_m == 0.020
    assert cfg.plant.modal_damping == 0.001
    assert cfg.dt_s == pytest.approx(47.619e-6, rel=1e-5)
    points = {p.name: p.x_m for p in cfg.plant.points}
    assert points == {"exc": 0.325, "frf": 0.45, "tip": 0.765}


def test_set_overrides_scalars_and_named_list_elements():
    cfg = load(sets=["plant.interface.mu=0.3", "plant.screws.adaptive.F_N=200", "plant.substeps=2"])
    assert cfg.plant.interface.mu == 0.3
    assert next(s for s in cfg.plant.screws if s.adaptive).F_N == 200.0
    assert cfg.plant.substeps == 2


def test_config_file_then_set(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text("[plant.interface]\nmu = 0.25\nk_t = 4e8\n")
    cfg = load(f, sets=["plant.interface.mu=0.35"])
    assert cfg.plant.interface.k_t == 4e8 and cfg.plant.interface.mu == 0.35


def test_dumped_configuration_loads_back_identical(tmp_path):
    cfg = load(sets=["plant.interface.k_n=2e9", "plant.screws.adaptive.F_N=150"])
    f = tmp_path / "resolved.toml"
    text = dumps(cfg)
    tomllib.loads(text)  # valid TOML
    f.write_text(text)
    assert to_dict(load(f)) == to_dict(cfg)


@pytest.mark.parametrize("assignment, words", [
    ("plant.interface.k_t=-5e8", ["plant.interface.k_t", "-500000000", "0 <", "N/m"]),
    ("plant.interface.k_n=0", ["plant.interface.k_n", "0"]),
    ("tracking.F_min_N=700", ["F_min_N", "700", "F_max_N", "600"]),
    ("plant.screws.adaptive.x_m=0.7", ["adaptive", "0.7", "0.465", "0.625"]),
    ("plant.screws.normal.x_m=0.1", ["normal", "0.1", "outside the damper"]),
    ("plant.interface.mu=nan", ["plant.interface.mu", "nan", "0 <= value <= 2"]),
    ("plant.beams.main.E=inf", ["plant.beams[main].E", "inf"]),
    ("plant.modal_damping=-0.01", ["plant.modal_damping", "-0.01"]),
    ("plant.screws.adaptive.F_N=10", ["F_N", "10", "F_min_N"]),
    ("plant.interface.pitch_m=0.03", ["pitch_m", "0.03", "whole pitches"]),
    ("plant.beams.damper.z0_m=0.01", ["damper", "z0_m", "0.008"]),
    ("plant.interface.foo=1", ["unknown key", "plant.interface.foo"]),
    ("plant.screws.nosuch.F_N=1", ["nosuch", "adaptive"]),
    ("plant.substeps=1.5", ["plant.substeps", "integer"]),
    ("plant.interface.lower=nosuch", ["plant.interface.lower", "nosuch"]),
    ("no_equals_sign", ["KEY=VALUE"]),
])
def test_bad_values_are_refused_with_key_value_and_range(assignment, words):
    with pytest.raises(ConfigError) as exc:
        load(sets=[assignment])
    msg = str(exc.value)
    for w in words:
        assert w in msg, f"{w!r} missing from: {msg}"


def test_bad_files_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="not found"):
        load(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[plant\nmu = ")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load(bad)
    wrong = tmp_path / "wrong.toml"
    wrong.write_text("[plant.interface]\nmu = 'high'\n")
    with pytest.raises(ConfigError, match="plant.interface.mu"):
        load(wrong)


def test_every_numeric_field_has_a_finite_default():
    def walk(d):
        for v in d.values():
            if isinstance(v, dict):
                yield from walk(v)
            elif isinstance(v, list):
                for x in v:
                    yield from walk(x)
            elif isinstance(v, float):
                yield v
    assert all(math.isfinite(v) for v in walk(to_dict(load())))
