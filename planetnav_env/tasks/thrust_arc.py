"""ThrustArc-TCM: a navigation-operations task in which imaging costs mission time.

Description
    21 days of ion thrust before an encounter E (DS1-like: 92 mN, 486 kg), where turning the camera to a
    planet turns the thrust axis away (delta-v lost), and what counts is the knowledge mapped to E at three
    trajectory-correction-manoeuvre (TCM) deadlines, E-14 d, E-5 d and E-1.5 d, plus 129.6 km per m/s of
    delta-v lost.

Action space
    ``Discrete(4)``: image planet k (0 Venus, 1 Mars, 2 Earth), or 3: stay at the thrust attitude (the
    engine thrusts).

Observation space
    Cruise-Target's blocks and the ``operations`` block (time to each deadline, delta-v lost, thrusting);
    v1 and v2 add ``since_measured``.

Reward
    Every version: the increments of the objective J, ``-(w * delta-v lost this step + the deadline terms
    reached this step) / 1000 km``, summing to ``-J / 1000 km``; the deadline term is the filter's
    predicted 1-sigma mapped to the encounter (``reward: covariance``), computable on board.

Episode end
    Truncated after 3,024 physics steps of 600 s (the encounter); terminated when the true position error
    exceeds 100,000 km.

Version history
    - v0: the first published version, one decision per 600-s step.
    - v1: posed for learners: the ``since_measured`` block.
    - v2: v1 deciding once per 2-h imaging session (12 steps), so a discount of 0.995 per decision spans
      ~17 days and every knowledge deadline (7, 16 and 19.5 days from the start) lies within reach of the
      decision that pays for it.
    - v3: v2 in the flight world, the true mapped error at the deadlines, posed for learners
      (docs/tasks_v3.md).

The card, ``docs/tasks/ThrustArc-TCM.md``, is generated from :data:`THRUST_ARC_TCM`
(``python -m planetnav_train.suite.cards``).
"""

from __future__ import annotations

import dataclasses

from planetnav_env.config import OperationsSettings
from planetnav_env.tasks.constants import v3_reward
from planetnav_env.tasks.spec import Card, Interface, Layout, Params, Reward, TaskSpec, TaskVersion
from planetnav_env.world import WorldConfig

_LAYOUT = Layout("random-cruise", ("venus", "mars", "earth"), "target", idle_action=True)
#: The arc: 600-s steps over 21 days; the engine and its execution errors, the deadlines and the exchange
#: rate of delta-v lost (``OperationsSettings`` gives each one's unit and meaning).
_ARC = Params(
    step_s=600.0,
    episode_steps=3024,
    operations=OperationsSettings(
        thrust_n=0.092,
        mass_kg=486.0,
        thrust_mag_sigma=0.02,
        thrust_point_sigma_deg=1.0,
        thrust_corr_time_s=86400.0,
        attitude_tolerance_deg=1.0,
        deadlines_s=(604800.0, 1382400.0, 1684800.0),
        encounter_s=1814400.0,
        cost_weight=129.6,
    ),
)

THRUST_ARC_TCM = TaskSpec(
    "ThrustArc-TCM",
    versions=(
        TaskVersion(
            0,
            layout=_LAYOUT,
            params=_ARC,
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(),
            note="the first published version: one decision per 600-s physics step",
        ),
        TaskVersion(
            1,
            layout=_LAYOUT,
            params=_ARC,
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(since_measured=True),
            note="v0 posed for learners: the `since_measured` block; benchmarked in suite version 1 "
            "(archived)",
        ),
        TaskVersion(
            2,
            layout=_LAYOUT,
            params=_ARC,
            reward=Reward("covariance", scale_km=1000.0),
            interface=Interface(decision_steps=12, since_measured=True),
            note="v1 deciding once per 2-h imaging session (`decision_steps: 12`), so a discount of 0.995 "
            "per decision (~17 days) reaches the knowledge deadlines at 7, 16 and 19.5 days; nothing is "
            'drawn that v1 does not draw ([tasks_v2.md](../tasks_v2.md), "Posing fixes"); benchmarked in '
            "suite version 2",
        ),
        TaskVersion(
            3,
            layout=Layout(
                "random-cruise",
                ("venus", "mars", "earth"),
                "target",
                idle_action=True,
                blocks=("residual_log", "momentum"),
            ),
            params=dataclasses.replace(_ARC, world=WorldConfig.coerce("flight")),
            reward=v3_reward("ThrustArc-TCM"),
            interface=Interface(decision_steps=12, since_measured=True, observation_scaling="unit"),
            note="v2's arc and 2-h sessions in the flight world, the deadline terms the true error mapped to "
            "the encounter (`reward: truth`), less a time-only baseline at a measured scale (`python -m "
            "planetnav_train.suite.v3 reward`), the observation in unit scaling with the `residual_log` "
            "block and the wheel momentum (`momentum`: a dump costs engine time) "
            "([tasks_v3.md](../tasks_v3.md)); suite version 3",
        ),
    ),
    card=Card(
        lead="A navigation-operations task in which imaging costs mission time: 21 days of ion thrust before "
        "an encounter, where turning the camera to a planet turns the engine off, and what counts is the "
        "knowledge at three trajectory-correction-manoeuvre (TCM) deadlines.",
        physics="""\
Scenario `random-cruise` arcs ([RandomCruise-Target](RandomCruise-Target.md#physics)) with 600-s steps,
3,024 steps (21 days); the encounter E is the episode's end. A DS1-like ion engine (92 mN, 486 kg) thrusts
along the planned direction while the thrust axis is within 1° of it; imaging a planet slews away, so the
Δv of that time is lost. Execution errors (2 % in magnitude, 1° in pointing, 1-day correlation time) grow
the covariance as process noise, the same noise in the truth and the filter, so the NEES stays exact.
Knowledge deadlines: E−14 d, E−5 d, E−1.5 d. The reward is scored by
`planetnav_env.core.operations.score_operations` whatever `reward` names, and `tests/env/test_operations.py`
holds its sum to J; `info` carries `dv_lost_m_s`, `deadline_sigma_km`, `deadline_err_km` and `objective`
(docs/environment.md, "Info keys"). The covariance does not depend on the measured values and the deadlines
are known before the arc, so a schedule anchored on the deadlines gets most of what any planner gets.
Pages: [environment.md](../environment.md) (the `operations` options).""",
        commands=(
            "python train.py compare --config configs/operations/thrust_arc_tcm.yaml   # the rules, seeds "
            "10000-10019",
            "python train.py train --config configs/operations/thrust_arc_tcm.yaml     # a short PPO run, "
            "then the rules",
            "python train.py suite-references --tasks ThrustArc-TCM-v2",
            "python train.py suite --tasks ThrustArc-TCM-v2 --track raw --seeds 0 1 2 3 4 --out runs/suite "
            "--resume",
        ),
    ),
    module=__name__,
)
