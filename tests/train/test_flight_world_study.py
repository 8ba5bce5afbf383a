"""The flight-world study command (research/commands/flight_world_study.py) end to end on short episodes:
its summaries are the statistics of the per-episode values it writes, the two worlds share the seeds, and
the per-effect table switches each listed effect off."""

from __future__ import annotations

import json

import numpy as np
import pytest

from planetnav_env.world import flight_effects


@pytest.fixture
def study(research_command):
    return research_command("flight_world_study")


def test_agents_table_summaries_are_the_episodes_statistics(tmp_path, capsys, study) -> None:
    out = tmp_path / "agents.json"
    argv = [
        "agents",
        "--seeds",
        "3",
        "--agents",
        "baseline",
        "--scenarios",
        "cruise",
        "--episode-steps",
        "30",
    ]
    assert study.main([*argv, "--json", str(out)]) == 0
    rec = json.loads(out.read_text())["results"]["cruise"]["baseline"]
    assert set(rec) == {"matched", "flight"}
    for world in rec.values():
        episodes = world["episodes"]
        assert len(episodes) == 3
        final = np.array([e["final_err_km"] for e in episodes])
        assert world["summary"]["final_err_km"]["mean"] == pytest.approx(final.mean())
        low, high = world["summary"]["final_err_km"]["low"], world["summary"]["final_err_km"]["high"]
        assert low < final.mean() < high
        assert all(e["nees"] > 0 for e in episodes)
    # The same seeds and noise streams: the two worlds start from the same error, and then part.
    m, f = rec["matched"]["episodes"], rec["flight"]["episodes"]
    assert [e["final_err_km"] for e in m] != [e["final_err_km"] for e in f]
    table = capsys.readouterr().out
    assert "| cruise | baseline | matched |" in table and "| cruise | baseline | flight |" in table


def test_shares_table_has_one_row_per_listed_effect(tmp_path, capsys, study) -> None:
    out = tmp_path / "shares.json"
    argv = ["shares", "--seeds", "2", "--scenarios", "cruise", "--episode-steps", "20", "--json", str(out)]
    assert study.main(argv) == 0
    rows = json.loads(out.read_text())["results"]["cruise"]
    expected = flight_effects(thrust=False, pulsars=False)  # the cruise has neither
    assert set(rows) == {"flight", "matched"} | {f"flight, no {k}" for k in expected}


def test_an_unknown_agent_is_a_named_error(capsys, study) -> None:
    argv = ["agents", "--seeds", "2", "--agents", "nonesuch", "--scenarios", "cruise", "--episode-steps", "5"]
    assert study.main(argv) == 2
    assert "unknown agent 'nonesuch'" in capsys.readouterr().err
