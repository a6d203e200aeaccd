"""Config model: merge order, both medium forms, validation messages with lines."""
import pytest

from fogcli.api import make_config
from fogcli.config.model import VISIBILITY_CONTRAST
from fogcli.errors import UserError
from fogcli.config.presets import assemble, check_file, presets


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
    from fogcli.physics.calibration import c_theory

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
    assert (cfg.render.psf, cfg.render.border, cfg.render.emission_profile, cfg.render.ground) == \
        ("apsf", "extend", "lambertian", "auto")
    assert make_config("fog", sets=["render.method=naive"]).render.psf == "gaussian"
    assert make_config("fog", sets=["render.fetch=receiver"]).render.psf == "gaussian"
    with pytest.raises(UserError, match="render.psf: apsf needs render.method pyramid"):
        make_config("fog", sets=["render.method=naive", "render.psf=apsf"])
    with pytest.raises(UserError, match="render.emission_profile: lambertian .* needs render.psf: apsf"):
        make_config("fog", sets=["render.psf=gaussian", "render.emission_profile=lambertian"])
    with pytest.raises(UserError, match="render.border: extend .* needs render.psf: apsf"):
        make_config("fog", sets=["render.psf=gaussian", "render.border=extend"])
    with pytest.raises(UserError, match="render.border: expected one of open, closed, extend"):
        make_config("fog", sets=["render.border=mirror"])


# ---------------------------------------------------------------- typed model (issue 9)

VALID = [
    "", "medium:\n  visibility: 40\n", "medium:\n  visibility: 40\n  albedo: 0.5\n",
    "medium:\n  absorption: 0.1\n  scattering: [0.1, 0.2, 0.3]\n", "medium:\n  ambient: auto\n",
    "medium:\n  density:\n    - {type: sphere, radius: 3, center: [0, 0, -5]}\n",
    "medium:\n  density:\n    - {type: exponential, falloff: 0.1}\n    - {type: homogeneous, factor: 0.2}\n",
    "camera:\n  depth: disparity\n  baseline: 0.2\n", "camera:\n  depth: inverse\n  near: 1\n  far: 50\n",
    "camera:\n  empty_depth: inf\n", "camera:\n  depth_scale: 0.001\n", "camera:\n  calibrated_size: [640, 480]\n",
    "camera:\n  focal_px: null\n  cx: 3\n", "render:\n  method: naive\n", "render:\n  fetch: receiver\n",
    "render:\n  method: reference\n", "render:\n  kernel: 6\n  c: 0.8\n  epsilon: 0\n  levels: 5\n",
    "render:\n  separation: {enabled: true}\n", "render:\n  psf: gaussian\n  emission_profile: isotropic\n",
    "output:\n  type: half\n  compression: piz\n", "output:\n  exposure: -2\n", "medium:\n  asymmetry: 0\n",
]
INVALID = [
    ("medium:\n  visibility: 0\n", 2), ("medium:\n  visibility: 10\n  absorption: 1\n", None),
    ("medium:\n  albedo: 1.5\n", None), ("medium:\n  absorption: [1, 2]\n", 2), ("medium:\n  scattering: -1\n", 2),
    ("medium:\n  asymmetry: -0.1\n", 2), ("medium:\n  ambient: bright\n", 2), ("medium:\n  density: []\n", 2),
    ("medium:\n  density:\n    - {type: cube}\n", 3), ("medium:\n  density:\n    - {type: sphere, radius: -1}\n", 3),
    ("medium:\n  density:\n    - {type: homogeneous, falloff: 1}\n", 3), ("medium: 3\n", 1),
    ("camera:\n  fov: 180\n", 2), ("camera:\n  fov: true\n", 2), ("camera:\n  depth: disparity\n", None),
    ("camera:\n  depth: inverse\n  near: 5\n  far: 1\n", None), ("camera:\n  depth_scale: 0\n", 2),
    ("camera:\n  calibrated_size: [640]\n", 2), ("camera:\n  calibrated_size: [640.5, 480]\n", 2),
    ("camera:\n  empty_depth: -1\n", 2), ("camera:\n  position: [0, 0]\n", 2), ("camera:\n  max_depth: .nan\n", 2),
    ("render:\n  method: naive\n  psf: apsf\n", None), ("render:\n  psf: gaussian\n  emission_profile: lambertian\n", None),
    ("render:\n  method: naive\n  separation: {enabled: true}\n", None), ("render:\n  kernel: 8\n", 2),
    ("render:\n  levels: 0\n", 2), ("render:\n  levels: 2.5\n", 2), ("render:\n  c: -1\n", 2),
    ("render:\n  separation: {level: 2}\n", 2), ("render:\n  separation: yes please\n", 2), ("output:\n  type: int\n", 2),
    ("output:\n  compression: lzma\n", 2), ("output:\n  exposure: [1]\n", 2), ("outptu:\n  type: half\n", 1),
]


@pytest.mark.parametrize("text", VALID + [t for t, _ in INVALID])
def test_check_and_apply_agree(tmp_path, text):
    """check and apply run the same validation: ok for one is ok for the other, and apply's
    message is check's first problem (57 configs, valid and invalid)."""
    p = tmp_path / "c.yaml"
    p.write_text(text)
    problems = check_file(str(p))
    try:
        assemble("fog", str(p))
        applied = None
    except UserError as exc:
        applied = str(exc)
    assert (problems == []) == (applied is None) == (text in VALID), (problems, applied)
    if problems:
        assert applied.startswith(problems[0])
        line = dict(INVALID)[text]
        if line:
            assert problems[0].startswith(f"{p}:{line}:"), problems[0]


def test_messages_sorted_by_line_and_unclosed_bracket_at_its_line(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("render:\n  kernel: 3\nmedium:\n  asymmetry: 2\ncamera:\n  fov: 0\noutput:\n  type: x\n")
    lines = [int(q.split(":")[1]) for q in check_file(str(p))]
    assert lines == [2, 4, 6, 8]
    p.write_text("medium:\n  absorption: [1, 2\nrender:\n  kernel: 4\n")
    assert check_file(str(p))[0].startswith(f"{p}:2: invalid YAML: flow sequence opened here is not closed")


def test_docs_key_reference_is_generated_and_valid(tmp_path):
    from helpers import ROOT

    import make_config_doc

    text = (ROOT / "docs" / "config.md").read_text()
    assert make_config_doc.reference() in text, "docs/config.md is stale: run python tools/make_config_doc.py"
    block = make_config_doc.reference().split("```yaml\n", 1)[1].rsplit("```", 1)[0]
    (tmp_path / "ref.yaml").write_text(block)
    assert check_file(str(tmp_path / "ref.yaml")) == []
    from pydantic import BaseModel

    from fogcli.config.model import Config

    def keys(model, pre=""):
        for name, f in model.model_fields.items():
            sub = f.annotation if isinstance(f.annotation, type) and issubclass(f.annotation, BaseModel) else None
            yield from keys(sub, f"{pre}{name}.") if sub else [f"{pre}{name}"]
    documented, stack = [], []
    for ln in block.splitlines():
        if ln.strip().startswith(("#", "-")):
            continue
        depth = (len(ln) - len(ln.lstrip())) // 2
        stack = stack[:depth] + [ln.strip().split(":")[0]]
        if "# " in ln and not ln.rstrip().endswith(":"):
            documented.append(".".join(stack))
    assert sorted(documented) == sorted(keys(Config))           # every key once, each with its doc


def test_config_show_round_trips(tmp_path):
    from helpers import run

    code, text, _ = run("config", "--show", "--medium", "sea", "--set", "camera.empty_depth=inf")
    assert code == 0, text
    (tmp_path / "shown.yaml").write_text(text)
    assert check_file(str(tmp_path / "shown.yaml")) == []
    again = assemble("fog", str(tmp_path / "shown.yaml"))
    assert again == assemble("sea", None, ("camera.empty_depth=inf",)).model_copy(
        update={"render": again.render}) and again.camera.empty_depth == float("inf")
    assert "c: 0." in text and "epsilon: 1.5" in text          # auto resolved
    code, bare, _ = run("config", "--medium", "sea", "--set", "camera.empty_depth=inf")
    assert code == 0 and bare == text                           # --show is what the command does (issue 41)


@pytest.mark.parametrize("item", ["medium.absorption=", "medium.absorption= ", "camera.fov="])
def test_an_empty_set_value_is_refused(item):
    """Issue 41: `--set medium.absorption=` was taken as null, and the medium became empty."""
    from helpers import assert_one_line_error, run

    assert_one_line_error(*run("config", "--set", item)[:2], "empty value; expected a YAML value (null to unset the key)")
