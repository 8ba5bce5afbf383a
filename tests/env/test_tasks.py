"""The task declarations (planetnav_env.tasks) against the options the ids resolved to before them.

``tests/golden/id_options.json`` was written from the old registration (four merge layers over EnvConfig's
defaults, before the declarations replaced them): ``EnvConfig.from_dict(id_options(id)).to_dict()`` per
id. Every id must resolve to the same configuration, option by option, through the declaration, through
the registry (``id_options``) and through ``gym.make``.
"""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import ENV_IDS, id_options
from planetnav_env.errors import ConfigError
from planetnav_env.tasks import TASKS, VERSIONS, get_task, get_version
from planetnav_env.tasks.spec import Interface, Layout, Params, Reward

_RECORD = json.loads((Path(__file__).parents[1] / "golden" / "id_options.json").read_text())
ORACLE, OLD_DEFAULTS = _RECORD["ids"], _RECORD["defaults"]


def _same_configuration(now: dict, want: dict) -> dict:
    """The options on which ``now`` (a resolved configuration today) and ``want`` (recorded) differ. An
    option added since the record must be at today's default, and one removed since must have been at the
    recorded default, in every id: neither may change what an id is."""
    default = EnvConfig().to_dict()
    moved = {k: (v, want.get(k)) for k, v in now.items() if k in want and want[k] != v}
    moved |= {k: (v, "added") for k, v in now.items() if k not in want and v != default[k]}
    moved |= {k: ("removed", v) for k, v in want.items() if k not in now and v != OLD_DEFAULTS[k]}
    return moved


def test_the_comparison_can_fail():
    want = ORACLE["planetnav/Cruise-Target-v2"]["options"]
    assert _same_configuration({**want, "image_success_min": 1.0}, want) == {"image_success_min": (1.0, 0.0)}
    assert _same_configuration({**want, "filter": {**want["filter"], "sigma_pos0": 1.0}}, want)
    removed = {k: v for k, v in want.items() if k != "centroid_bias_max"}
    assert _same_configuration(removed, want) == {}  # an option removed at its default changes nothing
    assert _same_configuration(removed, {**want, "centroid_bias_max": 0.5}) == {
        "centroid_bias_max": ("removed", 0.5)
    }


def test_the_same_ids_are_registered():
    assert set(VERSIONS) == set(ORACLE) == set(ENV_IDS)
    assert len(VERSIONS) == 26
    assert all(env_id in gym.registry for env_id in ORACLE)


@pytest.mark.parametrize("env_id", sorted(ORACLE))
def test_every_id_resolves_to_the_recorded_configuration(env_id):
    want = ORACLE[env_id]["options"]
    declared = get_version(env_id).config().to_dict()
    registered = EnvConfig.from_dict(id_options(env_id)).to_dict()
    env = gym.make(env_id)
    made = env.unwrapped.config.to_dict()
    env.close()
    # Option by option, so a failure names what moved.
    for now in (declared, registered, made):
        assert _same_configuration(now, want) == {}
    assert declared == registered == made


@pytest.mark.parametrize("env_id", sorted(ORACLE))
def test_rule_agents_play_the_physics_step_of_the_same_task(env_id):
    """The declared rule interface is the one the rule agents played before (``at_physics_step``)."""
    v = get_version(env_id)
    assert EnvConfig.from_dict(v.rule_options()) == v.config().at_physics_step()


def test_v0_and_v1_differ_only_in_reward_and_interface():
    """The cards state the v1 references for v0: the rule agents play both on one configuration but for
    the reward, which no rule agent reads."""
    for task in TASKS:
        v0, v1 = task.versions[0], task.versions[1]
        a, b = EnvConfig.from_dict(v0.rule_options()), EnvConfig.from_dict(v1.rule_options())
        assert {k for k, x in a.to_dict().items() if b.to_dict()[k] != x} <= {"reward"}, task.name


def test_lookups_and_bad_declarations_name_the_value():
    assert get_version("Cruise-Target-v2") is get_version("planetnav/Cruise-Target-v2")
    assert get_task("Cruise-Target").latest.version == 3
    with pytest.raises(ConfigError, match="Cruise-Target-v9"):
        get_version("Cruise-Target-v9")
    with pytest.raises(ConfigError, match="'orbit'"):
        Layout("orbit", ("venus",), "target")
    with pytest.raises(ConfigError, match="'image_logs'"):
        Layout("cruise", ("venus",), "target", blocks=("image_logs",))
    with pytest.raises(ConfigError, match="'sideways'"):
        Interface(target_actions="sideways")
    with pytest.raises(ConfigError, match="-1"):
        Reward("truth", scale_km=-1.0)
    with pytest.raises(ConfigError, match="world"):
        Params(step_s=60.0, episode_steps=10, world="mars")  # type: ignore[arg-type]
