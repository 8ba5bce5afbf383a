"""RandomCruise-Target: target choice as in Cruise-Target, on a new cruise every reset.

Description
    The epoch, the transfer arc and the initial estimate error come from the reset seed, so a policy has
    to generalise across geometries instead of memorising one day. Which planets are usable changes from
    episode to episode: the observable-if-pointed column and the 1-sigma across each line of sight say so.

Action space
    ``Discrete(3)``: the planet to point at, 0 Venus, 1 Mars, 2 Earth (v0: absolute; v1 and v2: relative).

Observation space
    Cruise-Target's blocks; v1 adds ``since_measured``; v2 the ``image_log`` and the
    ``position_correlation`` of the filter's position covariance.

Reward
    v0: ``-|r_est - r_true| / 1000 km`` per physics step (privileged). v1, v2: ``-sqrt(trace P_rr) / 1000
    km``, summed over a decision.

Starting state
    v0, v1: the initial error drawn from the spherical prior of ``filter.sigma_pos0`` (1000 km per axis).
    v2: 5,000 km along a direction drawn uniformly per episode and 50 km across it; the filter starts from
    that covariance, so a rule reading P_rr knows which way the error lies.

Episode end
    Terminated when the true position error exceeds 100,000 km, truncated after 1,440 physics steps.

Version history
    - v0: the first published version: the true-error reward, one decision per 60-s step.
    - v1: posed for learners: the covariance reward, decisions held 10 steps, relative target actions and
      the ``since_measured`` block.
    - v2: v1 with image failures the filter does not model (a success rate per planet drawn uniformly from
      [0, 1] per episode, the image log observed) and a prior shaped by a navigation history (long along a
      drawn direction, its correlations observed).
    - v3: v2's conditions in the flight world, posed for learners (docs/tasks_v3.md).

The card, ``docs/tasks/RandomCruise-Target.md``, is generated from :data:`RANDOM_CRUISE_TARGET`
(``python -m planetnav_train.suite.cards``).
"""

from __future__ import annotations

from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.tasks.constants import V3_POSING, v3_reward
from planetnav_env.tasks.spec import Card, Interface, Layout, Params, Reward, TaskSpec, TaskVersion

_PLANETS = ("venus", "mars", "earth")

RANDOM_CRUISE_TARGET = TaskSpec(
    "RandomCruise-Target",
    versions=(
        TaskVersion(
            0,
            layout=Layout("random-cruise", _PLANETS, "target"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("truth", scale_km=1000.0),
            interface=Interface(),
            note="the first published version: the true-error reward, one decision per physics step",
        ),
        TaskVersion(
            1,
            layout=Layout("random-cruise", _PLANETS, "target"),
            params=Params(step_s=60.0, episode_steps=1440),
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(decision_steps=10, target_actions="relative", since_measured=True),
            note="v0's physics posed for learners: the on-board covariance reward, decisions held 10 "
            "physics steps (600 s), relative target actions and the `since_measured` block; benchmarked in "
            "suite version 1 (archived)",
        ),
        TaskVersion(
            2,
            layout=Layout("random-cruise", _PLANETS, "target", blocks=("image_log", "position_correlation")),
            params=Params(
                step_s=60.0,
                episode_steps=1440,
                image_success_min=0.0,
                prior_long_sigma_km=5000.0,
                filter=FilterConfig(sigma_pos0=50.0),
            ),
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(decision_steps=10, target_actions="relative", since_measured=True),
            note="v1 where each planet's images yield a fix with a probability drawn uniformly from [0, 1] "
            "per episode (`image_success_min: 0`), unknown to the filter, the observation carrying the image "
            "log; and the prior is 5,000 km along a direction drawn uniformly per episode and 50 km across "
            "it (`prior_long_sigma_km: 5000`, `filter.sigma_pos0: 50`: the filter's P0, so the observed "
            "`position_correlation` says which way the error lies) ([tasks_v2.md](../tasks_v2.md)); "
            "benchmarked in suite version 2",
        ),
        TaskVersion(
            3,
            layout=Layout(
                "random-cruise",
                _PLANETS,
                "target",
                blocks=("image_log", "residual_log", "position_correlation"),
            ),
            params=Params(
                step_s=60.0,
                episode_steps=1440,
                image_success_min=0.0,
                prior_long_sigma_km=5000.0,
                filter=FilterConfig(sigma_pos0=50.0),
                world="flight",
            ),
            reward=v3_reward("RandomCruise-Target"),
            interface=Interface(decision_steps=10, since_measured=True, observation_scaling="unit"),
            note="v2's per-episode conditions (image success rates drawn per planet, the prior shaped by a "
            "navigation history) " + V3_POSING + "; suite version 3",
        ),
    ),
    card=Card(
        lead="Target choice as in [Cruise-Target](Cruise-Target.md), but every reset draws a new cruise: the "
        "epoch, the transfer arc and the initial estimate error come from the reset seed, so a policy has to "
        "generalise across geometries instead of memorising one day.",
        physics="""\
Scenario `random-cruise` (`planetnav_env/scenarios/episodes.py`): epoch uniform in 2018-2032, a transfer
ellipse between the orbits of Venus and Mars (perihelion 0.70-0.75 AU, aphelion 1.45-1.60 AU, inclination
0-3°) with uniform node, perihelion and mean anomaly, kept only if at least two of the planets are within
1.5 AU and more than 10° outside the camera's Sun-exclusion cone. Everything else as in
[Cruise-Target](Cruise-Target.md#physics): 60-s steps, 1,440 steps, PD law, star fix, EKF. Which planets
are usable changes from episode to episode: the observable-if-pointed column and the 1σ across each line
of sight say so. The 100 evaluation seeds are 100 different cruises.""",
        commands=(
            "python train.py train --config configs/random_cruise_ppo.yaml   # DAgger clone of greedy on "
            "`gain`, then PPO",
            "python train.py suite-references --tasks RandomCruise-Target-v2",
            "python train.py suite --tasks RandomCruise-Target-v2 --track raw --seeds 0 1 2 3 4 --out "
            "runs/suite --resume",
        ),
    ),
    module=__name__,
)
