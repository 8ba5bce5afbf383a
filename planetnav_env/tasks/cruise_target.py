"""Cruise-Target: choose which planet the star camera looks at, once a minute, for one day of the
thesis's Venus-to-Mars transfer.

Description
    The attitude control (the thesis's PD law on three reaction wheels) does the pointing; the agent's
    choice decides what the navigation filter learns. One planet's line of sight leaves the range along it
    unobservable: switching between planets triangulates it, at the price of the slews.

Action space
    ``Discrete(3)``: the planet to point at, 0 Venus, 1 Mars, 2 Earth (v0: absolute; v1 and v2: relative,
    0 keeps the current target and k moves k places).

Observation space
    ``Box`` of float32 from what the spacecraft knows, never the truth (``ObservationLayout``): the filter's
    state and 1-sigma, the star tracker's attitude, rates, wheel momenta, seven columns per planet, the target
    one-hot, the elapsed fraction; v1 adds ``since_measured``, v2 the ``image_log``.

Reward
    v0: ``-|r_est - r_true| / 1000 km`` per physics step (privileged). v1, v2: ``-sqrt(trace P_rr) / 1000
    km``, the filter's own predicted RMS error, summed over a decision.

Episode end
    Terminated when the true position error exceeds 100,000 km, truncated after 1,440 physics steps.

Version history
    - v0: the first published version: the true-error reward, one decision per 60-s step.
    - v1: posed for learners: the covariance reward, decisions held 10 steps, relative target actions and
      the ``since_measured`` block; the physics, seeds and objective of v0.
    - v2: v1 with image failures the filter does not model: each planet's images yield a fix with a
      probability drawn uniformly from [0, 1] per episode, and the observation carries the image log.
    - v3: v2's conditions in the flight world, posed for learners (docs/tasks_v3.md): the true-error reward
      less a time-only baseline at a measured scale, absolute targets, unit-scaled observation with the
      residual log.

The card, ``docs/tasks/Cruise-Target.md``, is generated from :data:`CRUISE_TARGET`
(``python -m planetnav_train.suite.cards``).
"""

from __future__ import annotations

from planetnav_env.tasks.constants import V3_POSING, v3_reward
from planetnav_env.tasks.spec import Card, Interface, Layout, Params, Reward, TaskSpec, TaskVersion

CRUISE_TARGET = TaskSpec(
    "Cruise-Target",
    versions=(
        TaskVersion(
            0,
            layout=Layout("cruise", ("venus", "mars", "earth"), "target"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("truth", scale_km=1000.0),
            interface=Interface(),
            note="the first published version: the true-error reward, one decision per physics step",
        ),
        TaskVersion(
            1,
            layout=Layout("cruise", ("venus", "mars", "earth"), "target"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(decision_steps=10, target_actions="relative", since_measured=True),
            note="v0's physics posed for learners: the on-board covariance reward, decisions held 10 "
            "physics steps (600 s), relative target actions and the `since_measured` block; benchmarked in "
            "suite version 1 (archived)",
        ),
        TaskVersion(
            2,
            layout=Layout("cruise", ("venus", "mars", "earth"), "target", blocks=("image_log",)),
            params=Params(step_s=60.0, episode_steps=1440, image_success_min=0.0),
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(decision_steps=10, target_actions="relative", since_measured=True),
            note="v1 where each planet's images yield a fix with a probability drawn uniformly from [0, 1] "
            "per episode (`image_success_min: 0`), told neither to the filter nor to the agent (a failed "
            'image gives no measurement, `info["visibility"] == "image_failed"`), and the observation '
            "carries the image log ([tasks_v2.md](../tasks_v2.md)); benchmarked in suite version 2",
        ),
        TaskVersion(
            3,
            layout=Layout(
                "cruise", ("venus", "mars", "earth"), "target", blocks=("image_log", "residual_log")
            ),
            params=Params(step_s=60.0, episode_steps=1440, image_success_min=0.0, world="flight"),
            reward=v3_reward("Cruise-Target"),
            interface=Interface(decision_steps=10, since_measured=True, observation_scaling="unit"),
            note="v2's per-episode conditions (each planet's image success rate drawn uniformly from [0, 1]) "
            + V3_POSING
            + "; suite version 3",
        ),
    ),
    card=Card(
        lead="Choose which planet the star camera looks at, once a minute, for one day of the thesis's "
        "Venus→Mars transfer. The attitude control (the thesis's PD law on three reaction wheels) does the "
        "pointing; the choice decides what the navigation filter learns.",
        physics="""\
Scenario `cruise`: heliocentric two-body orbit (RK4) on the transfer from 2020-08-01 (docs/angular_size.md),
60-s steps, 1,440 steps (one day). Each step: 60 one-second attitude sub-steps (10-s sub-steps once a held
target has settled) of the rigid body with three wheels (0.01 N m, 0.5 N m s), the PD law slewing toward the
*estimated* direction of the chosen planet; a star fix by the q-method from the stars in the camera's 16°
field; the camera measures the planet's line of sight and angular diameter when it is visible (in the
field, outside the 30° Sun-exclusion cone, not occulted, above the detection threshold); the EKF (6
states, χ²-gated) updates. The initial estimate error is drawn from P0 (1000 km, 1 m/s per axis) and the
initial attitude uniformly, from the reset seed. One planet's line of sight leaves the range along it
unobservable: switching between planets triangulates it, at the price of the slews. The episode terminates
when the true position error exceeds 100,000 km (divergence) and is truncated after 1,440 physics steps.
Pages: [environment.md](../environment.md), [attitude.md](../attitude.md), [camera.md](../camera.md),
[filter.md](../filter.md), [angular_size.md](../angular_size.md).""",
        commands=(
            "python train.py                                   # PPO on this task (configs/cruise_ppo.yaml), "
            "then every agent",
            "python train.py compare --agents planner greedy periodic baseline random idle   # the rules, "
            "seeds 10000-10019",
            "python train.py suite-references --tasks Cruise-Target-v2",
            "python train.py suite --tasks Cruise-Target-v2 --track raw --seeds 0 1 2 3 4 --out runs/suite "
            "--resume",
        ),
    ),
    module=__name__,
)
