"""The typed configuration: SPEC defaults, overrides, validation messages, round trip."""
import math
import tomllib
import warnings

import pytest

from frictionrt.rt.common.config import ConfigError, dumps, load, loads, to_dict


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
    # the pitch is a numerical choice fixed by convergence (docs/plant.md 6.3), not a SPEC value
    assert cfg.plant.interface.mu == 0.4 and cfg.plant.interface.pitch_m == 0.010
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
    f.write_text("[plant.interface]\nmu = 0.25\nk_t_area = 5e11\n")
    cfg = load(f, sets=["plant.interface.mu=0.35"])
    assert cfg.plant.interface.k_t_area == 5e11 and cfg.plant.interface.mu == 0.35


def test_per_pair_contact_keys_refused_in_a_file_converted_in_a_log(tmp_path):
    """SPEC 2: the contact is per unit area. A user's file with the earlier per-pair k_n [N/m] gets
    one line with the per-area value (k_n over one 20 x 40 mm pair); a configuration stored in a
    log (loads(stored=True)) is converted, with a warning, to the same value."""
    f = tmp_path / "old.toml"
    f.write_text("[plant.interface]\npitch_m = 0.02\nk_n = 1.6e9\nk_t = 8e8\n")
    with pytest.raises(ConfigError, match=r"old.toml: plant.interface.k_n = 1600000000.0 N/m per pair .*"
                                          r"k_n_area = 2e\+12 N/m\^3") as err:
        load(f)
    assert "\n" not in str(err.value)
    with pytest.warns(UserWarning, match="per pair is no longer a key"):
        cfg = loads(f.read_text(), stored=True)
    assert cfg.plant.interface.k_n_area == pytest.approx(2e12, rel=1e-15)
    assert cfg.plant.interface.k_t_area == pytest.approx(1e12, rel=1e-15)


def test_a_stored_layout_keeps_the_points_it_ran_with(tmp_path):
    """The default refines the contact pitch at the interface's ends (end_refinement = 2) since stop
    40. A configuration stored in a log before it ran at a uniform pitch: without end_refinement it
    loads with 1, with the earlier end_pitch_m (with a warning) pitch_m / end_pitch_m; a user's
    file with end_pitch_m gets one line naming the key that replaces it."""
    f = tmp_path / "old.toml"
    f.write_text("[plant.interface]\npitch_m = 0.01\n")
    assert loads(f.read_text(), stored=True).plant.interface.end_refinement == 1
    assert load(f).plant.interface.end_refinement == 2
    f.write_text("[plant.interface]\npitch_m = 0.01\nend_pitch_m = 0.0\nend_zone_m = 0.0\n")   # stops 38-39's logs
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # the uniform layout they ran: converted without a word
        assert loads(f.read_text(), stored=True).plant.interface.end_refinement == 1
    f.write_text("[plant.interface]\npitch_m = 0.01\nend_pitch_m = 0.0025\nend_zone_m = 0.03\n")
    with pytest.warns(UserWarning, match="end_pitch_m = 0.0025 m is no longer a key"):
        cfg = loads(f.read_text(), stored=True)
    assert (cfg.plant.interface.end_refinement, cfg.plant.interface.end_zone_m) == (4, 0.03)
    with pytest.raises(ConfigError, match=r"old.toml: .*use plant.interface.end_refinement = 4 ") as err:
        load(f)
    assert "\n" not in str(err.value)


def test_dumped_configuration_loads_back_identical(tmp_path):
    cfg = load(sets=["plant.interface.k_n_area=2.5e12", "plant.screws.adaptive.F_N=150"])
    f = tmp_path / "resolved.toml"
    text = dumps(cfg)
    tomllib.loads(text)  # valid TOML
    f.write_text(text)
    assert to_dict(load(f)) == to_dict(cfg)


@pytest.mark.parametrize("assignment, words", [
    ("plant.interface.k_t_area=-5e11", ["plant.interface.k_t_area", "-500000000000", "0 <", "N/m^3"]),
    ("plant.interface.k_n_area=0", ["plant.interface.k_n_area", "0"]),
    ("plant.interface.k_n=1.7e9", ["plant.interface.k_n ", "per pair", "plant.interface.k_n_area = 4.25e+12 N/m^3"]),
    ("plant.interface.x_end_m=0.465", ["x_end_m", "0.465", "must exceed"]),
    ("tracking.F_min_N=700", ["F_min_N", "700", "F_max_N", "600"]),
    ("plant.screws.adaptive.x_m=0.7", ["adaptive", "0.7", "0.465", "0.625"]),
    ("plant.screws.normal.x_m=0.1", ["normal", "0.1", "outside the damper"]),
    ("plant.interface.mu=nan", ["plant.interface.mu", "nan", "0 <= value <= 2"]),
    ("plant.beams.main.E=inf", ["plant.beams[main].E", "inf"]),
    ("plant.modal_damping=-0.01", ["plant.modal_damping", "-0.01"]),
    ("plant.screws.adaptive.F_N=10", ["F_N", "10", "F_min_N"]),
    ("plant.interface.pitch_m=0.03", ["pitch_m", "0.03", "whole pitches"]),
    ("plant.interface.end_pitch_m=0.0025", ["end_pitch_m", "no longer a key", "end_refinement = 4"]),
    ("plant.interface.end_refinement=0", ["plant.interface.end_refinement", "0", "1 <= value <= 8"]),
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
