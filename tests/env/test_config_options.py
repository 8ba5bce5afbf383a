"""The option declarations (planetnav_env.options): every option's checks, named errors, the generated
docs table and the kernel scalars that copy options."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from planetnav_env.config import OPTION_PAGES, EnvConfig
from planetnav_env.core.ephemeris_table import SEGMENT_S
from planetnav_env.errors import ConfigError, OptionError, OptionTypeError, UnknownOptionError
from planetnav_env.kernel_params import SCALAR_FIELDS, SCALARS_DTYPE
from planetnav_env.options import kernel_fields, kernel_values, option, replace_table, walk

DOCS = Path(__file__).resolve().parents[2] / "docs" / "environment.md"
LEAVES = [(path, opt) for path, opt, _ in walk(EnvConfig) if opt.kind != "section"]


def _config(path: str, value):
    """EnvConfig.from_dict with ``value`` at the dotted ``path`` (a section's options as a mapping)."""
    head, _, leaf = path.rpartition(".")
    if not head:
        return EnvConfig.from_dict({path: value})
    extra = {"action_mode": "target", "idle_action": True} if head == "operations" else {}
    return EnvConfig.from_dict({head: {leaf: value}, **extra})


def _bad_values(opt) -> list[tuple[str, object, type]]:
    """(what, value, error class) of values the declaration must reject: a wrong type, below and above its
    range, a length off."""
    item = {"floats": "float", "ints": "int", "strs": "str", "matrix": "float"}.get(opt.kind, opt.kind)
    out: list[tuple[str, object, type]] = []
    out.append(("type", True if item == "str" else "x", OptionTypeError))
    if item == "float":
        out.append(("non-finite", math.nan, OptionError))
    if item == "int":
        out.append(("fraction", 0.5, OptionTypeError))
    if item == "bool":
        out.append(("int", 1, OptionTypeError))
    if opt.choices is not None:
        out.append(("not a choice", "no-such-choice", OptionError))
    for what, bound, step in (
        ("below", opt.gt, 0),
        ("below", opt.ge, -1),
        ("above", opt.lt, 0),
        ("above", opt.le, 1),
    ):
        if bound is not None:
            out.append((what, bound + step, OptionError))

    def seq(value):
        if opt.kind == "matrix":
            return [[value] * opt.length[1]] * opt.length[0]
        n = opt.length[0] if opt.length else 1
        return [value] * max(n, 1)

    if opt.kind in ("floats", "ints", "strs", "matrix"):
        out = [
            (what, seq(v) if what != "type" else seq(5 if item == "str" else "x"), err)
            for what, v, err in out
        ]
        good = 1 if item != "str" else "venus"
        lo, hi = opt.length or (0, None)
        if hi is not None and opt.kind != "matrix":
            out.append(("too long", [good] * (hi + 1), OptionError))
        if lo > 1:
            out.append(("too short", [good] * (lo - 1), OptionError))
        if opt.kind == "matrix":
            out.append(("shape", [[1.0, 0.0], [0.0, 1.0]], OptionError))
    return out


CASES = [
    pytest.param(path, value, err, id=f"{path}-{what}")
    for path, opt in LEAVES
    for what, value, err in _bad_values(opt)
]


@pytest.mark.parametrize("path,value,err", CASES)
def test_each_option_rejects_a_bad_value_naming_it(path: str, value, err: type) -> None:
    with pytest.raises(err) as info:
        _config(path, value)
    msg = str(info.value)
    assert msg.startswith(f"{path} must be "), msg
    assert f"got {value!r} ({type(value).__name__})" in msg, msg


def test_every_leaf_option_has_a_bad_value_case() -> None:
    assert len(LEAVES) >= 55
    covered = {c.values[0] for c in CASES}
    assert covered == {path for path, _ in LEAVES}


@pytest.mark.parametrize("path,opt", LEAVES, ids=[p for p, _ in LEAVES])
def test_each_default_passes_and_each_declaration_matches_its_annotation(path: str, opt) -> None:
    _, default = next((p, d) for p, o, d in walk(EnvConfig) if p == path)
    _config(path, default)  # the default, given explicitly, is accepted
    head, _, leaf = path.rpartition(".")
    owner = EnvConfig if not head else next(o.section for p, o, _ in walk(EnvConfig) if p == head)
    annotation = owner.__dataclass_fields__[leaf].type
    expected = {
        "floats": "tuple[float",
        "ints": "tuple[int",
        "strs": "tuple[str",
        "matrix": "tuple[tuple[float",
    }
    assert annotation.startswith(expected.get(opt.kind, opt.kind)), (path, annotation, opt.kind)
    assert opt.doc, path


def test_named_messages() -> None:
    with pytest.raises(
        OptionTypeError, match=r"^step_s must be a finite number \(float, s\) > 0, got '60' \(str\)$"
    ):
        EnvConfig(step_s="60")
    assert isinstance(OptionTypeError("x", "y", 1), TypeError)
    with pytest.raises(
        OptionError, match=r"^step_s must be .* in \(0, 726695\.35\] for scenario 'cruise' and "
    ):
        EnvConfig(step_s=1e7)
    with pytest.raises(
        OptionError,
        match=r"^camera\.focal_length_mm must be a finite number \(float, mm\) > 0, got -1 \(int\)$",
    ):
        EnvConfig.from_dict({"camera": {"focal_length_mm": -1}})
    with pytest.raises(
        OptionError, match=r"^torque_action_scale must be .* in \(0, 1\], got 2\.0 \(float\)$"
    ):
        EnvConfig(torque_action_scale=2.0)
    with pytest.raises(OptionTypeError, match=r"^camera must be CameraConfig .*, got 5 \(int\)$"):
        EnvConfig(camera=5)
    with pytest.raises(UnknownOptionError, match="unexpected keyword argument 'step'"):
        EnvConfig.from_dict({"step": 60})
    with pytest.raises(ConfigError, match=r"unknown option camera\.'focal_mm'"):
        EnvConfig.from_dict({"camera": {"focal_mm": 20}})


@pytest.mark.parametrize(
    "scenario,planets", [("cruise", None), ("random-cruise", None), ("mars-approach", ["mars"])]
)
def test_step_bound_is_the_ephemeris_span(scenario: str, planets) -> None:
    """The bound the error names passes, a step a segment longer over the episode does not; a valid
    config's episode lies in the DE421 span."""
    kw = {"scenario": scenario, **({"planets": planets} if planets else {})}
    with pytest.raises(OptionError) as info:
        EnvConfig(step_s=1e8, **kw)
    bound = float(str(info.value).split("in (0, ")[1].split("]")[0])
    cfg = EnvConfig(step_s=bound, attitude_substep_s=bound, settled_substep_s=0, **kw)
    with pytest.raises(OptionError, match="step_s"):
        EnvConfig(step_s=bound + 2 * SEGMENT_S / (cfg.episode_steps + 1), **kw)


def test_integral_numbers_and_yaml_lists_are_normalised_but_numbers_keep_their_type() -> None:
    cfg = EnvConfig.from_dict(
        {"step_s": 60, "episode_steps": 10.0, "planets": ["Mars"], "star_tracker_bias_arcsec": [1, 2, 3]}
    )
    assert cfg.step_s == 60 and type(cfg.step_s) is int  # to_dict and YAML written from it stay as given
    assert cfg.episode_steps == 10 and type(cfg.episode_steps) is int
    assert cfg.planets == ("mars",) and cfg.star_tracker_bias_arcsec == (1.0, 2.0, 3.0)
    assert EnvConfig.from_dict(cfg.to_dict()) == cfg
    assert EnvConfig(
        camera=EnvConfig().camera, star_tracker_bias_arcsec=np.zeros(3)
    ).star_tracker_bias_arcsec == (
        0.0,
        0.0,
        0.0,
    )


@pytest.mark.parametrize("page", sorted(OPTION_PAGES))
def test_docs_option_tables_are_the_generated_ones(page: str) -> None:
    text = (DOCS.parents[1] / page).read_text()
    assert replace_table(text, OPTION_PAGES[page]()) == text, (
        f"{page}'s option table differs from the declarations: python -m planetnav_env.config"
    )


def test_every_option_is_in_one_generated_table() -> None:
    tables = "".join(make() for make in OPTION_PAGES.values())
    for path, _, _ in walk(EnvConfig):
        assert tables.count(f"| `{path}` |") == 1, path


def test_kernel_scalars_copied_from_options() -> None:
    generated = kernel_fields(EnvConfig)
    assert SCALAR_FIELDS[: len(generated)] == generated
    names = [name for name, _, _ in SCALAR_FIELDS]
    assert len(names) == len(set(names)) == len(SCALARS_DTYPE.names)
    copied = {name: kind for name, kind, _ in generated}
    assert copied == {
        "step_s": "f8", "substep_s": "f8", "coarse_s": "f8", "episode_steps": "i8", "reward_scale": "f8",
        "torque_penalty": "f8", "torque_scale": "f8", "divergence": "f8", "ambig_k": "f8", "k_a": "f8",
        "k_w": "f8", "psr_int_s": "f8", "ops_encounter": "f8", "ops_weight": "f8", "img_min": "f8",
        "decision_steps": "i8",
    }  # fmt: skip
    # The world's effects are resolved against its preset before the core reads them (kernel_params).
    assert {"cob_max", "psr_df_max"} <= set(names) - set(copied)
    cfg = EnvConfig(torque_action_scale=0.25)
    values = kernel_values(cfg)
    assert values["torque_scale"] == 0.25 and values["step_s"] == cfg.step_s
    assert values["ops_encounter"] == 0 and values["ops_weight"] == 0  # no operations section


def test_a_declaration_needs_a_kind_it_cannot_infer() -> None:
    with pytest.raises(TypeError, match="declare it with kind="):
        option((1.0, 2.0), doc="a pair")


def test_a_section_override_updates_the_ids_section_and_a_presets_name() -> None:
    """``gym.make(id, filter={...})`` changes the keys given and keeps the id's other filter options; a
    world mapping over an id's preset name is that preset with the keys given."""
    from planetnav_env.tasks import get_version

    opts = get_version("planetnav/RandomCruise-Target-v2").options()
    assert opts["filter"]["sigma_pos0"] != EnvConfig().filter.sigma_pos0  # the id's own prior
    cfg = EnvConfig.from_dict(opts, filter={"accel_psd": 1e-12})
    assert cfg.filter.accel_psd == 1e-12
    assert cfg.filter.sigma_pos0 == opts["filter"]["sigma_pos0"]
    v3 = get_version("planetnav/Cruise-Target-v3").options()
    assert EnvConfig.from_dict(v3).world.preset == "flight"
    for base in (v3, {"world": "flight"}):  # the id's world section, and a preset's name
        cfg = EnvConfig.from_dict(base, world={"lambert_cob": False})
        assert cfg.world.preset == "flight" and cfg.world.lambert_cob is False
        assert EnvConfig.from_dict(base, world={"preset": "matched"}).world.preset == "matched"
        assert EnvConfig.from_dict(base, world="matched").world.preset == "matched"  # a name replaces
    with pytest.raises(OptionError, match="world"):
        EnvConfig.from_dict({"world": "nowhere"}, world={"srp": True})
