"""The compiled action decoding (:mod:`planetnav_env.core.decoding`) against the rules as the action
spaces state them, and the environments' use of it: relative targets, the idle action, clipping, the
first maximum on ties, hybrid mode's two options."""

from __future__ import annotations

import numpy as np
import pytest

from planetnav_env.core.decisions import relative_targets, relative_to_absolute
from planetnav_env.core.decoding import decode_actions, raw_action_size
from planetnav_env.core.layout import MODE_HYBRID, MODE_TARGET, MODE_TARGET_TORQUE, MODE_TORQUE
from planetnav_env.envs.spaces import decode_hybrid
from planetnav_env.errors import InvalidParameterError

NONE = np.full(4, -1, dtype=np.int64)


def test_absolute_targets_and_the_idle_action() -> None:
    raw = np.array([[0.0], [2.0], [3.0], [1.0]])  # T = 3: action 3 is the idle action
    targets, torques = decode_actions(MODE_TARGET, False, 2, 3, raw, NONE)
    assert targets.tolist() == [0, 2, -1, 1]
    assert not torques.any()


def test_relative_targets_count_from_the_current_target() -> None:
    raw = np.array([[0.0], [1.0], [2.0], [2.0]])
    current = np.array([-1, 2, 1, 2], dtype=np.int64)  # -1: no target yet, counted from target 0
    targets, _ = decode_actions(MODE_TARGET, True, 2, 3, raw, current)
    assert targets.tolist() == [0, 0, 0, 1]  # (max(c, 0) + k) mod 3
    assert relative_targets(raw[:, 0], current, 3).tolist() == targets.tolist()
    assert relative_to_absolute(2, 2, 3) == 1
    with pytest.raises(InvalidParameterError, match=r"relative action of row 1 .* got 3"):
        relative_targets(np.array([0, 3]), np.array([0, 0]), 3)


def test_torque_is_clipped_and_keeps_its_sign() -> None:
    raw = np.array([[1.5, -2.0, -0.0], [0.25, -1.0, 1.0], [0.0, 0.0, 0.0], [-0.5, 0.5, 3.0]])
    targets, torques = decode_actions(MODE_TORQUE, False, 2, 3, raw, NONE)
    assert targets.tolist() == [-1] * 4
    assert torques.tobytes() == np.clip(raw, -1.0, 1.0).tobytes()  # -0.0 stays -0.0, as np.clip gives


def test_target_and_torque_first_maximum_of_the_clipped_scores() -> None:
    # P = 3 scores, then the residual torque; 1.5 and 1.2 both clip to 1.0: the first wins the tie.
    raw = np.array([[0.1, 1.5, 1.2, 0.3, -0.3, 2.0], [-1.0, -1.0, -1.0, 0.0, 0.0, 0.0]])
    targets, torques = decode_actions(MODE_TARGET_TORQUE, False, 3, 3, raw, NONE[:2])
    assert targets.tolist() == [1, 0]
    assert torques.tolist() == [[0.3, -0.3, 1.0], [0.0, 0.0, 0.0]]


def test_hybrid_planet_option_or_direct_torque() -> None:
    # P = 2: options (planet 0, planet 1, direct torque), then the torque.
    raw = np.array([
        [0.9, 0.1, 0.5, 0.2, 0.3, 0.4],  # planet 0 by the PD law: the torque is ignored
        [0.0, 0.2, 0.7, 2.0, -0.5, 0.1],  # direct torque, clipped
        [1.0, 0.3, 4.0, 0.6, 0.6, 0.6],  # 1.0 and clip(4.0) = 1.0 tie: the planet (the first) wins
    ])  # fmt: skip
    targets, torques = decode_hybrid(raw, 2)
    assert targets.tolist() == [0, -1, 0]
    assert torques.tolist() == [[0.0] * 3, [1.0, -0.5, 0.1], [0.0] * 3]
    assert raw_action_size(MODE_HYBRID, 2) == raw.shape[1]


def test_the_env_steps_the_decoded_target() -> None:
    """A relative action moves the row's target as the rule says, in the single and the vector env."""
    import gymnasium as gym

    import planetnav_env  # noqa: F401 - registers the ids

    env_id = "planetnav/Cruise-Target-v1"

    env = gym.make(env_id)
    env.reset(seed=0)
    seen = []
    for a in (1, 0, 2, 1):
        seen.append(env.step(a)[4]["target_index"])
    assert seen == [1, 1, 0, 1]  # T = 3 from none: 1, keep, +2 -> 0, +1 -> 1
    vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    vec.reset(seed=0)
    vec.step(np.array([1, 2]))
    assert vec.unwrapped.current_targets().tolist() == [1, 2]
    with pytest.raises(InvalidParameterError, match=r"row 1 must be an integer in \[0, 3\), got 3"):
        vec.step(np.array([0, 3]))
