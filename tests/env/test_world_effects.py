"""The flight world's list of effects (``world.flight_effects``), which the per-effect share study switches
off one at a time: it names every effect the preset turns on, and each named setting really turns it off."""

from __future__ import annotations

import pytest

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.envs.registration import id_options
from planetnav_env.world import EFFECTS_OFF, WorldConfig, flight_effects


def _all_off() -> dict:
    return {k: v for off in EFFECTS_OFF.values() for k, v in off.items()}


def test_switching_off_every_listed_effect_leaves_the_matched_world() -> None:
    assert flight_effects() == EFFECTS_OFF
    assert not WorldConfig(preset="flight").is_matched
    assert WorldConfig(preset="flight", **_all_off()).is_matched


#: The id each effect acts on: the thrust arc's for the thrust's effects, the Mars approach's (pulsars) for
#: the pulsars', the cruise's for the rest.
_ID = {"thrust_gauss_markov": "ThrustArc-TCM-v2", "disturbance_torques": "ThrustArc-TCM-v2"}
_ID["pulsar_shapiro"] = "MarsApproach-Tasking-v2"


@pytest.mark.parametrize("name", sorted(EFFECTS_OFF))
def test_each_listed_effect_alone_changes_what_the_core_runs(name: str) -> None:
    """The world with every effect off but this one runs other kernel scalars than the world with all off
    (so its off setting is what switches it), and is not the matched world."""
    others = {k: v for n, off in EFFECTS_OFF.items() if n != name for k, v in off.items()}
    alone = WorldConfig(preset="flight", **others)
    assert not alone.is_matched, name
    scalars = []
    for world in (alone, WorldConfig(preset="flight", **_all_off())):
        core = BatchCore(EnvConfig.from_dict({**id_options(f"planetnav/{_ID.get(name, 'Cruise-Target-v2')}"),
                                              "world": world}), 1)  # fmt: skip
        scalars.append(core.params.scalars[0])
    assert scalars[0].tobytes() != scalars[1].tobytes(), name


def test_scenarios_without_thrust_or_pulsars_leave_their_effects_out() -> None:
    assert "thrust_gauss_markov" not in flight_effects(thrust=False)
    assert "pulsar_shapiro" not in flight_effects(pulsars=False)
    assert set(flight_effects(thrust=False, pulsars=False)) == set(EFFECTS_OFF) - {
        "thrust_gauss_markov",
        "pulsar_shapiro",
    }
