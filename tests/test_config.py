"""Config model: merge order, both medium forms, validation messages with lines."""
import pytest

from fogcli.api import make_config
from fogcli.config import VISIBILITY_CONTRAST
from fogcli.errors import UserError
from fogcli.media import assemble, check_file, presets


def test_every_preset_is_valid_and_has_a_source_comment():
    names = set(presets())
    assert {"fog", "haze", "sea", "harbour", "smoke"} <= names
    for name, path in presets().items():
        assert check_file(str(path)) == []
        text = path.read_text()
        assert text.startswith("#") and any(ch.isdigit() for ch in text.split("medium:")[0])


def test_visibility_form_and_override_order(tmp_path):
    cfg = make_config("fog")
    st = sum(cfg.medium.absorption) / 3 + sum(cfg.medium.scattering) / 3
    assert st == pytest.approx(VISIBILITY_CONTRAST / 150)
    assert cfg.medium.scattering[0] / st == pytest.approx(0.999)
    # --config overrides the preset, --set overrides --config; a later form drops the other
    conf = tmp_path / "c.yaml"
    conf.write_text("medium:\n  absorption: 0.1\n  scattering: [0.2, 0.3, 0.4]\nrender:\n  kernel: 6\n")
    cfg = assemble("fog", str(conf), ("render.kernel=2",))
    assert cfg.medium.absorption == (0.1, 0.1, 0.1) and cfg.medium.scattering == (0.2, 0.3, 0.4)
    assert cfg.render.kernel == 2
    cfg = assemble("sea", None, ("medium.visibility=10",))
    assert cfg.medium.scattering[0] == pytest.approx(0.9 * VISIBILITY_CONTRAST / 10)
    cfg = assemble("sea", None, ("medium.albedo=0.5",))   # albedo alone redistributes sigma_t
    assert cfg.medium.absorption[1] == pytest.approx(cfg.medium.scattering[1])
    assert cfg.medium.absorption[1] + cfg.medium.scattering[1] == pytest.approx(0.0565 + 0.037)


def _err(tmp_path, text):
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(UserError) as e:
        assemble("fog", str(p))
    return str(e.value)


@pytest.mark.parametrize("text,line,needle", [
    ("medium:\n  absorbtion: 0.1\n", 2, "did you mean absorption"),
    ("render:\n  kernel: 5\n", 2, "render.kernel: expected one of 2, 4, 6"),
    ("medium:\n  scattering: [0.1, -0.2, 0.1]\n", 2, "medium.scattering[1]"),
    ("medium:\n  asymmetry: 1.0\n", 2, "medium.asymmetry"),
    ("camera:\n  fov: wide\n", 2, "camera.fov: expected a number"),
    ("medium:\n  density:\n    - {type: exponential, direction: [0, 0, 0]}\n", 3, "non-zero direction"),
    ("medium:\n  density:\n    - type: sphere\n      radius: 0\n", 4, "radius"),
    ("render:\n  method: fast\n", 2, "render.method"),
    ("output:\n  type: 3\n", 2, "output.type: expected one of"),
    ("foo: 1\n", 1, "foo: unknown key"),
    ("medium: [1, 2\n", None, "invalid YAML"),
])
def test_bad_values_name_file_line_and_key(tmp_path, text, line, needle):
    msg = _err(tmp_path, text)
    assert needle in msg
    assert "bad.yaml" in msg
    if line:
        assert f"bad.yaml:{line}:" in msg


def test_check_reports_every_problem(tmp_path):
    p = tmp_path / "two.yaml"
    p.write_text("medium:\n  asymmetry: 2\nrender:\n  kernel: 3\n  bogus: 1\n")
    problems = check_file(str(p))
    assert len(problems) == 3
    assert any(":2:" in q for q in problems) and any(":4:" in q for q in problems) and any(":5:" in q for q in problems)


def test_set_errors_and_unknown_preset():
    with pytest.raises(UserError, match="expected KEY=VALUE"):
        assemble("fog", None, ("render.kernel",))
    with pytest.raises(UserError, match="--set render.kernl.*did you mean kernel"):
        assemble("fog", None, ("render.kernl=4",))
    with pytest.raises(UserError, match="no such preset"):
        assemble("fogg")


def test_derived_c_and_calibrated_defaults():
    from fogcli.config import c_theory

    # 4 taps (1,3,3,1)/8 have variance 3/4; a bicubic B-spline fetch adds 1/3
    assert c_theory(4, "linear-bicubic", "receiver") == pytest.approx((0.75 / 3 + 1 / 3) ** 0.5)
    assert c_theory(4, "linear-bicubic", "source") == pytest.approx((0.75 / 3 + 4 / 9) ** 0.5)
    assert c_theory(6, "linear-bilinear", "receiver") == pytest.approx((1.25 / 3 + 1 / 6) ** 0.5)
    cfg = make_config("fog")
    c, eps, thr = cfg.render.resolved()
    assert c == pytest.approx(c_theory(4, "linear-bicubic", "source"))
    naive = make_config("fog", sets=["render.method=naive"]).render.resolved()
    assert naive[0] == pytest.approx(c_theory(4, "linear-bicubic", "receiver"))
    assert make_config("fog", sets=["render.c=0.5", "render.epsilon=0"]).render.resolved()[:2] == (0.5, 0.0)


def test_psf_border_and_emission_profile_keys():
    """apsf is the default of the composites that can carry it; naive and the receiver
    fetch are Gaussian models: asking them for apsf is an error, leaving it out is not."""
    cfg = make_config("fog")
    assert (cfg.render.psf, cfg.render.border, cfg.render.emission_profile) == ("apsf", "open", "lambertian")
    assert make_config("fog", sets=["render.method=naive"]).render.psf == "gaussian"
    assert make_config("fog", sets=["render.fetch=receiver"]).render.psf == "gaussian"
    with pytest.raises(UserError, match="render.psf: apsf needs render.method pyramid"):
        make_config("fog", sets=["render.method=naive", "render.psf=apsf"])
    with pytest.raises(UserError, match="render.emission_profile: lambertian .* needs render.psf: apsf"):
        make_config("fog", sets=["render.psf=gaussian", "render.emission_profile=lambertian"])
    with pytest.raises(UserError, match="render.border: expected one of open, closed"):
        make_config("fog", sets=["render.border=mirror"])
