"""MarsApproach-Tasking: sensor tasking on the final approach to Mars (the patent's case).

Description
    Every 5 minutes, image Mars with the star camera or time one of two X-ray pulsars with a co-aligned
    detector, over 94 h ending 2 h before closest approach; the filter settings of docs/optical_pulsar.md.

Action space
    ``Discrete(3)``: 0 image Mars, 1 time the Crab (B0531+21), 2 time B1937+21 (v0: absolute; v1 and v2:
    relative); the PD law points camera and detector.

Observation space
    Cruise-Target's blocks with positions relative to Mars, one planet block and two pulsar blocks; v1
    adds ``since_measured``, v2 the ``image_log`` of Mars.

Reward
    v0: ``-|r_est - r_true| / 10 km`` per physics step (privileged). v1, v2: ``-sqrt(trace P_rr) / 10 km``,
    summed over a decision.

Episode end
    Terminated when the true position error exceeds 100,000 km, truncated after 1,128 physics steps.

Version history
    - v0: the first published version: the true-error reward, one decision per 300-s step.
    - v1: posed for learners: the covariance reward, decisions held 4 steps (20 min, a pulsar integration
      is ~1,000 s), relative target actions and the ``since_measured`` block.
    - v2: v1 with image failures of Mars the filter does not model, its image log observed.
    - v3: v2's conditions in the flight world, posed for learners (docs/tasks_v3.md).

The card, ``docs/tasks/MarsApproach-Tasking.md``, is generated from :data:`MARS_APPROACH_TASKING`
(``python -m planetnav_train.suite.cards``).
"""

from __future__ import annotations

from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.tasks.constants import V3_POSING, v3_reward
from planetnav_env.tasks.spec import Card, Interface, Layout, Params, Reward, TaskSpec, TaskVersion

_PULSARS = ("B0531+21", "B1937+21")
#: docs/optical_pulsar.md's filter: 100 km and 1 m/s initial 1-sigma per axis, process noise PSD 1e-16.
_FILTER = FilterConfig(sigma_pos0=100.0, sigma_vel0=1e-3, accel_psd=1e-16)

MARS_APPROACH_TASKING = TaskSpec(
    "MarsApproach-Tasking",
    versions=(
        TaskVersion(
            0,
            layout=Layout("mars-approach", ("mars",), "target", pulsars=_PULSARS),
            params=Params(step_s=300.0, episode_steps=1128, filter=_FILTER),
            reward=Reward("truth", scale_km=10.0),
            interface=Interface(),
            note="the first published version: the true-error reward, one decision per physics step",
        ),
        TaskVersion(
            1,
            layout=Layout("mars-approach", ("mars",), "target", pulsars=_PULSARS),
            params=Params(step_s=300.0, episode_steps=1128, filter=_FILTER),
            reward=Reward("covariance", scale_km=10.0),
            interface=Interface(decision_steps=4, target_actions="relative", since_measured=True),
            note="v0's physics posed for learners: the on-board covariance reward, decisions held 4 physics "
            "steps (1,200 s), relative target actions and the `since_measured` block; benchmarked in suite "
            "version 1 (archived)",
        ),
        TaskVersion(
            2,
            layout=Layout("mars-approach", ("mars",), "target", pulsars=_PULSARS, blocks=("image_log",)),
            params=Params(step_s=300.0, episode_steps=1128, filter=_FILTER, image_success_min=0.0),
            reward=Reward("covariance", scale_km=10.0),
            interface=Interface(decision_steps=4, target_actions="relative", since_measured=True),
            note="v1 where Mars's images yield a fix with a probability drawn uniformly from [0, 1] per "
            "episode (`image_success_min: 0`), told neither to the filter nor to the agent, and the "
            "observation carries Mars's image log ([tasks_v2.md](../tasks_v2.md)); benchmarked in suite "
            "version 2",
        ),
        TaskVersion(
            3,
            layout=Layout(
                "mars-approach", ("mars",), "target", pulsars=_PULSARS, blocks=("image_log", "residual_log")
            ),
            params=Params(
                step_s=300.0, episode_steps=1128, filter=_FILTER, image_success_min=0.0, world="flight"
            ),
            reward=v3_reward("MarsApproach-Tasking"),
            interface=Interface(decision_steps=4, since_measured=True, observation_scaling="unit"),
            note="v2's per-episode conditions (Mars's image success rate drawn from [0, 1]) "
            + V3_POSING
            + "; suite version 3",
        ),
    ),
    card=Card(
        lead="Sensor tasking on the final approach to Mars (the patent's case): every 5 minutes, image Mars "
        "with the star camera or time one of two X-ray pulsars with a co-aligned detector.",
        physics="""\
Scenario `mars-approach` (`planetnav_env/scenarios/approach.py`, [optical_pulsar.md](../optical_pulsar.md)):
Mars-centred dynamics with Sun, Earth and Jupiter perturbations (DE421), hyperbolic arrival at 2.65 km/s,
periapsis 400 km, closest approach 2021-02-10 12:00 TDB. 300-s steps, 1,128 steps (94 h), ending 2 h before
closest approach. Targets: Mars (camera: line of sight and angular size), the Crab (B0531+21) and
B1937+21 (X-ray detector: 1 m², 2° field, 1000-s integrations; a phase arrives when an integration
completes, its cycle ambiguity resolved against the prediction or skipped if 3σ reaches half a cycle).
Filter: 100 km and 1 m/s initial 1σ per axis, process noise PSD 1e-16 km²/s³. The observation's positions
are relative to Mars (/ 10⁶ km, velocities / 5 km/s); a pulsar block holds its direction in body axes,
integration progress, log10 predicted phase 1σ, observable 0/1 and log10 of the position 1σ along it.
`periodic` (cycles over planets) has no schedule with one planet, so it is not a reference candidate.
Pages: [optical_pulsar.md](../optical_pulsar.md), [environment.md](../environment.md).""",
        commands=(
            "python train.py suite-references --tasks MarsApproach-Tasking-v2",
            "python train.py suite --tasks MarsApproach-Tasking-v2 --track raw --seeds 0 1 2 3 4 --out "
            "runs/suite --resume",
        ),
    ),
    module=__name__,
)
