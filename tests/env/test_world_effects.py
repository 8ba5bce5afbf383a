"""The flight world's list of effects (``world.flight_effects``), which the per-effect share study switches
off one at a time: it names every effect the preset turns on, and each named value really turns it off."""

from __future__ import annotations

import pytest

from planetnav_env.world import EFFECTS_OFF, EPHEMERIDES, WorldConfig, flight_effects


def test_switching_off_every_listed_effect_leaves_the_matched_world() -> None:
    effects = flight_effects()
    assert effects == EFFECTS_OFF
    assert not WorldConfig(preset="flight").is_matched
    assert WorldConfig(preset="flight", **effects).is_matched


@pytest.mark.parametrize("name", sorted(EFFECTS_OFF))
def test_each_listed_effect_alone_moves_the_matched_world(name: str) -> None:
    off = EFFECTS_OFF[name]
    on = (not off) if isinstance(off, bool) else next(e for e in EPHEMERIDES if e != off)
    assert not WorldConfig(**{name: on}).is_matched
    assert WorldConfig(**{name: off}).is_matched


def test_scenarios_without_thrust_or_pulsars_leave_their_effects_out() -> None:
    assert "thrust_gauss_markov" not in flight_effects(thrust=False)
    assert "pulsar_shapiro" not in flight_effects(pulsars=False)
    assert set(flight_effects(thrust=False, pulsars=False)) == set(EFFECTS_OFF) - {
        "thrust_gauss_markov",
        "pulsar_shapiro",
    }
