"""Cruise-TorqueControl and Cruise-Hybrid: decisions at the attitude's own timescale, one a second for
one hour of the cruise.

Description
    The thesis's h = 1 s over one hour: the PD loop's time constant is ~20 s and a 90-degree slew takes
    ~100 s, so a 1-s step resolves a slew and 3,600 steps leave room for tens of slews between the planets.
    Cruise-TorqueControl: the agent's wheel torque, held 1 s. Cruise-Hybrid: each second either an option,
    "slew to planet k with the PD law", or a direct wheel torque
    (``planetnav_env.envs.spaces.decode_hybrid``).

Action space
    Cruise-TorqueControl: ``Box(-1, 1, (3,))``, wheel torque in body axes, 0.01 N m per unit.
    Cruise-Hybrid: ``Box(-1, 1, (7,))``, option ``argmax(a[:4])``; k < 3 slews to planet k, k = 3 applies
    the torque ``a[4:]``.

Observation space
    Cruise-Target's blocks and the ``in_field`` block (one 0/1 per planet); v1 adds ``since_measured``.

Reward
    v0: ``-|r_est - r_true| / 1000 km`` per physics step (privileged). v1: ``-sqrt(trace P_rr) / 1000 km``.

Episode end
    Terminated when the true position error exceeds 100,000 km, truncated after 3,600 physics steps.

Version history
    - v0: the first published versions.
    - v1: posed for learners: the covariance reward and the ``since_measured`` block; the 1-s decision,
      which is the point of these tasks, is kept.

The cards, ``docs/tasks/Cruise-TorqueControl.md`` and ``docs/tasks/Cruise-Hybrid.md``, are generated from
:data:`CRUISE_TORQUE_CONTROL` and :data:`CRUISE_HYBRID` (``python -m planetnav_train.suite.cards``).
"""

from __future__ import annotations

from planetnav_env.tasks.spec import Card, Interface, Layout, Params, Reward, TaskSpec, TaskVersion

_PLANETS = ("venus", "mars", "earth")
#: One-second physics: one attitude sub-step per step, no coarse settled sub-steps, an hour of steps.
_ONE_SECOND = Params(
    step_s=1.0, episode_steps=3600, attitude_substep_s=1.0, settled_substep_s=0.0, torque_action_scale=1.0
)


def _versions(action: str, v0_action_note: str) -> tuple[TaskVersion, TaskVersion]:
    """Both tasks' two versions, which differ only in the action kind: v0 with the true-error reward, v1
    the same physics with the on-board covariance reward and the ``since_measured`` block."""
    layout = Layout("cruise", _PLANETS, action, blocks=("in_field",))
    return (
        TaskVersion(
            0,
            layout=layout,
            params=_ONE_SECOND,
            reward=Reward("truth", scale_km=1000.0),
            interface=Interface(),
            note=f"the first published version: the true-error reward, {v0_action_note}",
        ),
        TaskVersion(
            1,
            layout=layout,
            params=_ONE_SECOND,
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(since_measured=True),
            note="v0's physics posed for learners: the on-board covariance reward and the `since_measured` "
            "block, one decision per 1-s physics step as in v0; benchmarked in suite version 1 (archived), "
            "the latest version",
        ),
    )


CRUISE_TORQUE_CONTROL = TaskSpec(
    "Cruise-TorqueControl",
    versions=_versions("torque", "the wheel torque held 1 s"),
    card=Card(
        lead="Wheel torques at the attitude's own timescale: one decision per second for one hour of the "
        "cruise, so a learner can resolve a slew (a 90° slew takes ~100 s) and has time for tens of them "
        "between the planets.",
        physics="""\
Scenario `cruise` with `step_s = 1`, one attitude sub-step per step, 3,600 steps (one hour, the thesis's
h = 1 s). The PD loop's time constant is ~20 s. The agent's torque is held for the second, clipped by the
wheel torque (0.01 N m) and momentum (0.5 N m s) limits; the camera measures the visible planet nearest its
boresight; star fix and EKF as in [Cruise-Target](Cruise-Target.md#physics). The reference `greedy-pd` is
greedy's choice of planet executed by the PD law through torques ([agents.md](../agents.md)).
Pages: [environment.md](../environment.md), "Wheel torques at the attitude's timescale";
[attitude.md](../attitude.md).""",
        commands=(
            "python train.py train --config configs/torque_control.yaml            # pure PPO, 3 M decisions",
            "python train.py train --config configs/torque_control_assisted.yaml   # rule features + a clone "
            "of greedy-pd",
            "python train.py suite-references --tasks Cruise-TorqueControl-v1",
            "python train.py suite --tasks Cruise-TorqueControl-v1 --track raw --seeds 0 1 2 3 4 --out "
            "runs/suite --resume",
        ),
    ),
    module=__name__,
)

CRUISE_HYBRID = TaskSpec(
    "Cruise-Hybrid",
    versions=_versions("hybrid", "an option or a torque each second"),
    card=Card(
        lead="One-second decisions as in [Cruise-TorqueControl](Cruise-TorqueControl.md), each either an "
        'option ("slew to planet k with the PD law") or a direct wheel torque.',
        physics="""\
As [Cruise-TorqueControl](Cruise-TorqueControl.md#physics): scenario `cruise`, 1-s steps, 3,600 steps; when
the option `k = argmax(a[:4])` is a planet (k < 3), the PD law's torque drives the wheels for that second
and `a[4:]` is ignored, otherwise (k = 3) the agent's torque `a[4:]` (0.01 N m per unit) does
(`planetnav_env.envs.spaces.decode_hybrid`). The camera measures the visible planet nearest its boresight.
`greedy-pd` scores as on Cruise-TorqueControl: the same choices executed by the same PD law under one
camera rule.""",
        commands=(
            "python train.py train --config configs/hybrid.yaml   # PPO with the since_measured feature, "
            "decisions held 10 s",
            "python train.py suite-references --tasks Cruise-Hybrid-v1",
            "python train.py suite --tasks Cruise-Hybrid-v1 --track raw --seeds 0 1 2 3 4 --out runs/suite "
            "--resume",
        ),
    ),
    module=__name__,
)
