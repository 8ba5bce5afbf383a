"""The flight world's list of effects (``world.flight_effects``), which the per-effect share study switches
off one at a time: it names every effect the preset turns on, and each named value really turns it off."""

from __future__ import annotations

import pytest

from planetnav_env.world import EFFECTS_OFF, WorldConfig, flight_effects


@pytest.mark.parametrize("scenario", ["cruise", "random-cruise"])
def test_switching_off_every_listed_effect_leaves_the_matched_world(scenario: str) -> None:
    effects = flight_effects(scenario)
    assert effects, "the flight preset turns effects on"
    assert not WorldConfig(preset="flight").is_matched
    assert WorldConfig(preset="flight", **effects).is_matched


@pytest.mark.parametrize("scenario", ["cruise", "random-cruise", "mars-approach"])
def test_each_listed_effect_alone_moves_the_world(scenario: str) -> None:
    for name, off in flight_effects(scenario).items():
        flight, one_off = WorldConfig(preset="flight"), WorldConfig(preset="flight", **{name: off})
        assert one_off != flight, name
        # Alone in the matched world, the effect's flight value makes it not matched.
        on = getattr(flight, name) if getattr(flight, name) is not None else _flight_value(name)
        assert not WorldConfig(**{name: on}).is_matched, name


def _flight_value(name: str) -> object:
    """The value the flight preset gives option ``name`` (its on value)."""
    off = EFFECTS_OFF[name]
    return (not off) if isinstance(off, bool) else None
