"""The task cards are what ``python -m planetnav_train.suite.cards`` writes from the declarations and the
suite's records (a card edited by hand, or a declaration or budget changed without rewriting the cards,
fails here)."""

from __future__ import annotations

import pytest

from planetnav_env.tasks import TASKS
from planetnav_train.suite import cards


@pytest.mark.parametrize("task", TASKS, ids=[t.name for t in TASKS])
def test_card_is_what_the_generator_writes(task):
    assert cards.card_path(task).read_text() == cards.render(task), (
        f"{cards.card_path(task)} is stale: run python -m planetnav_train.suite.cards"
    )


def test_check_mode_names_a_stale_card(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cards, "CARDS", tmp_path)
    assert cards.main([]) == 0  # writes every card into tmp_path
    (tmp_path / "Cruise-Target.md").write_text("edited by hand\n")
    assert cards.main(["--check"]) == 1
    assert "Cruise-Target.md" in capsys.readouterr().out
    assert (tmp_path / "Cruise-Target.md").read_text() == "edited by hand\n"  # --check writes nothing
