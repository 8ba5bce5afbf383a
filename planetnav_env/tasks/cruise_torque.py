"""Cruise-Torque and Cruise-TargetTorque: the one-day cruise of Cruise-Target with the agent on the
reaction wheels at the 60-s physics step.

Description
    Cruise-Torque: the agent commands the wheel torques itself (no PD law, no target choice), so pointing
    and navigation are learned together. Cruise-TargetTorque: both decisions, which planet the PD law
    slews to and a residual torque added to the PD command.

Action space
    Cruise-Torque: ``Box(-1, 1, (3,))``, the wheel torque on the body in body axes, in units of
    ``torque_action_scale`` times the wheel limit (0.01 N m), held for the step. Cruise-TargetTorque:
    ``Box(-1, 1, (6,))``, ``argmax(a[:3])`` the planet, ``a[3:]`` the residual torque.

Observation space
    Cruise-Target's blocks; v1 adds ``since_measured``.

Reward
    v0: ``-|r_est - r_true| / 1000 km`` per physics step (privileged). v1, v2: ``-sqrt(trace P_rr) / 1000
    km``, computable on board.

Episode end
    Terminated when the true position error exceeds 100,000 km, truncated after 1,440 physics steps.

Version history
    - v0: the first published versions.
    - v1: posed for learners: the covariance reward and the ``since_measured`` block; one decision per
      physics step, as in v0.
    - v2 (Cruise-Torque only): v1 with an action of 1 commanding 5 % of the wheel torque limit. A pointing
      torque held for a 60-s step is ~0.5 % of the limit, so at v1's scale a policy had to resolve its
      output to ~1e-3.
    - v3 (Cruise-Torque only): v2 in the flight world, posed for learners (docs/tasks_v3.md).

The cards, ``docs/tasks/Cruise-Torque.md`` and ``docs/tasks/Cruise-TargetTorque.md``, are generated from
:data:`CRUISE_TORQUE` and :data:`CRUISE_TARGET_TORQUE` (``python -m planetnav_train.suite.cards``).
"""

from __future__ import annotations

from planetnav_env.tasks.constants import v3_reward
from planetnav_env.tasks.spec import Card, Interface, Layout, Params, Reward, TaskSpec, TaskVersion

_PLANETS = ("venus", "mars", "earth")

CRUISE_TORQUE = TaskSpec(
    "Cruise-Torque",
    versions=(
        TaskVersion(
            0,
            layout=Layout("cruise", _PLANETS, "torque"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("truth", scale_km=1000.0),
            interface=Interface(),
            note="the first published version: the true-error reward, an action of 1 commanding the whole "
            "wheel torque limit",
        ),
        TaskVersion(
            1,
            layout=Layout("cruise", _PLANETS, "torque"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(since_measured=True),
            note="v0's physics posed for learners: the on-board covariance reward and the `since_measured` "
            "block, one decision per physics step as in v0; benchmarked in suite version 1 (archived)",
        ),
        TaskVersion(
            2,
            layout=Layout("cruise", _PLANETS, "torque"),
            params=Params(step_s=60.0, episode_steps=1440, torque_action_scale=0.05),
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(since_measured=True),
            note="v1 with an action of 1 commanding 5 % of the wheel torque limit (`torque_action_scale: "
            "0.05`, 0.0005 N m per body axis), so a pointing torque is resolvable: held for a 60-s step it "
            "is ~0.5 % of v1's range; nothing is drawn that v1 does not draw "
            '([tasks_v2.md](../tasks_v2.md), "Posing fixes"); benchmarked in suite version 2',
        ),
        TaskVersion(
            3,
            layout=Layout("cruise", _PLANETS, "torque", blocks=("residual_log", "momentum")),
            params=Params(step_s=60.0, episode_steps=1440, torque_action_scale=0.05, world="flight"),
            reward=v3_reward("Cruise-Torque"),
            interface=Interface(since_measured=True, observation_scaling="unit"),
            note="v2's torque scale in the flight world, posed for learners: the true-error reward less a "
            "time-only baseline at a measured scale (`python -m planetnav_train.suite.v3 reward`), the "
            "observation in unit scaling with the `residual_log` block and the wheel momentum (`momentum`) "
            "([tasks_v3.md](../tasks_v3.md)); suite version 3",
        ),
    ),
    card=Card(
        lead="The same one-day cruise as [Cruise-Target](Cruise-Target.md), but the agent commands the "
        "reaction wheels itself: no PD law, no target choice. Pointing and navigation have to be learned "
        "together.",
        physics="""\
As [Cruise-Target](Cruise-Target.md#physics): scenario `cruise`, 60-s steps, 1,440 steps, 1-s attitude
sub-steps, star fix, EKF. The agent's torque is held over the whole 60-s step, clipped by the wheel torque
(0.01 N m) and momentum (0.5 N m s) limits; values outside [-1, 1] are clipped and NaN or infinite values
raise `NonFiniteError`. The camera measures the visible planet nearest its boresight. Rule agents act
through the PD torque toward their chosen planet (`TargetAgent.torque_toward`).
Pages: [environment.md](../environment.md), [attitude.md](../attitude.md).""",
        commands=(
            "python train.py train --config configs/torque.yaml     # PPO on this task, then the comparison",
            "python train.py suite-references --tasks Cruise-Torque-v2",
            "python train.py suite --tasks Cruise-Torque-v2 --track raw --seeds 0 1 2 3 4 --out runs/suite "
            "--resume",
        ),
    ),
    module=__name__,
)

CRUISE_TARGET_TORQUE = TaskSpec(
    "Cruise-TargetTorque",
    versions=(
        TaskVersion(
            0,
            layout=Layout("cruise", _PLANETS, "target+torque"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("truth", scale_km=1000.0),
            interface=Interface(),
            note="the first published version: the true-error reward",
        ),
        TaskVersion(
            1,
            layout=Layout("cruise", _PLANETS, "target+torque"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(since_measured=True),
            note="v0's physics posed for learners: the on-board covariance reward and the `since_measured` "
            "block, one decision per physics step as in v0; benchmarked in suite version 1 (archived), the "
            "latest version",
        ),
    ),
    card=Card(
        lead="The one-day cruise with both decisions: which planet the PD law slews to, and a residual "
        "wheel torque added to the PD command.",
        physics="""\
As [Cruise-Target](Cruise-Target.md#physics): scenario `cruise`, 60-s steps, 1,440 steps. The PD law
slews toward the chosen planet; the agent's residual torque is added to its command, and the sum is
clipped by the wheel torque (0.01 N m) and momentum (0.5 N m s) limits. The action is one `Box` because
Stable-Baselines3 rejects `Dict` and `Tuple` action spaces.""",
        commands=(
            "python train.py train --config configs/target_torque.yaml   # target policy first, then "
            "distilled (DAgger)",
            "python train.py suite-references --tasks Cruise-TargetTorque-v1",
            "python train.py suite --tasks Cruise-TargetTorque-v1 --track raw --seeds 0 1 2 3 4 --out "
            "runs/suite --resume",
        ),
    ),
    module=__name__,
)
