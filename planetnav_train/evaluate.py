"""Evaluation on held-out seeds: every agent (rule-based, an SB3 model or an RLlib checkpoint) on the
same seeds, metrics with 95 % t-intervals (:func:`evaluate_agent`), paired differences from a reference
agent (:func:`add_paired`), the JSON written by the commands (:func:`results_json`), and the periodic
schedule sweep (:func:`sweep_periodic`).

A saved SB3 model is evaluated with its seeds as rows of the native vector env (:func:`batch_reason` says
when it cannot be): one batched ``model.predict`` per decision for all rows, through the training recipe's
layers (:class:`planetnav_train.batch_wrappers.TrainingOptions`: the features) over
:class:`~planetnav_env.envs.vector_env.PlanetNavVectorEnv` in the env's decision interface, each row one
episode from its own seed. Row ``i`` of the vector env is the single env seeded alike, bit for bit, and
the layers are the same code, so the per-episode results equal the one-episode-at-a-time path's given the
same actions (``tests/train/test_eval_batched.py``). The one difference can be the policy's forward pass:
a batched float32 matrix product rounds differently from the 1-row product (another BLAS blocking), in the
last bits. A discrete policy's argmax does not see it, so discrete (and multi-discrete) policies predict
all rows in one call. A continuous action is those bits, and an episode amplifies them (a measurement
accepted in one and rejected in the other: 1.5 % on one Cruise-Torque seed's J,
``benchmarks/bench_eval.py``), so by default (``exact_actions=True``) a continuous policy predicts row by
row, each row the very call the single-env path makes, while the env steps stay batched;
``exact_actions=False`` batches its predict too (faster; results equal only to float rounding on short
episodes). Sampled actions (``PATH@sampled``) batch as well: the single path seeds torch's global
generator with each episode's seed, and each row draws from its own copy of that state
(:func:`_sample_rows`), so the draws are the single path's. ``benchmarks/bench_eval.py`` measures the
speed-ups."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planetnav_agents import (
    NotApplicableError,
    acts_at_physics_step,
    make_agent,
    not_applicable,
    requires_idle_action,
)
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import DECISION_KEYS
from planetnav_train.batch_wrappers import RowsWrapper, TrainingOptions, VectorRows
from planetnav_train.config import REFERENCE
from planetnav_train.stats import mean_ci, paired_difference

#: Seeds of the periodic sweep: disjoint from the evaluation seeds (the chosen setting is not tuned on them).
SWEEP_SEED = 20_000


@dataclass
class EvalResult:
    """Metrics of one agent over held-out episodes, the per-episode values the statistics use, and the
    mean curves used by the plots. ``skipped`` holds the reason when the agent could not run here."""

    name: str
    metrics: dict[str, Any]
    pos_err_curve: np.ndarray
    pos_sigma_curve: np.ndarray
    episode_mean_err: np.ndarray = field(default_factory=lambda: np.zeros(0))  # km, one per seed
    seeds: tuple[int, ...] = ()
    skipped: str | None = None

    @property
    def ran(self) -> bool:
        """Whether the agent ran (it was not skipped)."""
        return self.skipped is None


def _skipped(name: str, reason: str) -> EvalResult:
    """The row of an agent that could not act in this environment, with the reason."""
    return EvalResult(name, {"skipped": reason}, np.zeros(0), np.zeros(0), skipped=reason)


def _episode(agent: Any, env: Any, seed: int, on_step: Callable[[], None]) -> dict[str, Any]:
    """One episode of ``agent`` from ``seed``: the per-step errors and the episode's totals."""
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    err, sig, vel, measured = [], [], [], 0
    slews, ret, diverged = 0, 0.0, False
    t0 = time.perf_counter()
    held = env.unwrapped.config.decision_steps > 1
    while True:
        obs, reward, terminated, truncated, info = env.step(agent.act(obs, info))
        # A held decision ran several physics steps: the record is per physics step (the objective's mean).
        steps = env.unwrapped.held if held else {k: [info[k]] for k in DECISION_KEYS}
        err += list(steps["pos_err_km"])
        sig += list(steps["pos_sigma_km"])
        vel += list(steps["vel_err_km_s"])
        measured += int(np.sum(steps["measured"]))
        slews += int(np.sum(steps["slewing"]))
        ret += float(reward)
        on_step()
        if terminated or truncated:
            diverged = bool(terminated)
            break
    return _episode_record(
        np.asarray(err), np.asarray(sig), np.asarray(vel), measured, slews, ret, diverged,
        time.perf_counter() - t0, info,
    )  # fmt: skip


def _episode_record(
    err: np.ndarray,
    sig: np.ndarray,
    vel: np.ndarray,
    measured: int,
    slews: int,
    ret: float,
    diverged: bool,
    seconds: float,
    final_info: dict[str, Any],
) -> dict[str, Any]:
    """One episode's record, the one form of the single and the batched paths: per-step position error
    ``err`` and 1-sigma ``sig`` [km], velocity error ``vel`` [km/s], the measured and slewing step counts,
    the return, whether it diverged, its wall time [s] and the objective from its last ``final_info``."""
    return {
        "pos_err": err,
        "pos_sigma": sig,
        "mean_vel_err_km_s": float(np.mean(vel)),
        "measured_fraction": measured / len(err),
        "slews": slews,
        "return": ret,
        "diverged": diverged,
        "seconds": seconds,
        "objective": episode_objective(final_info, err),
    }


def episode_objective(final_info: dict[str, Any], pos_err_km: np.ndarray) -> float:
    """The scenario objective J of one episode [km], lower is better: ``info["objective"]`` at the
    episode's end on an operations scenario (the sum of the deadline terms plus w x dv lost); on scenarios
    without operations, the episode's mean position error [km] (the same number as
    ``per_episode_mean_pos_err_km``), so that every evaluation has the objective fields."""
    if "objective" in final_info:
        return float(final_info["objective"])
    return float(np.mean(pos_err_km))


#: Rows per vector env in the batched evaluation (the suite's 100 seeds make one batch).
EVAL_BATCH_ROWS = 100


def batch_reason(agent: Any, exact_actions: bool = True) -> str | None:
    """Why ``agent`` cannot be evaluated with its seeds as rows of one vector env, or None when it can.

    Batched: a saved SB3 model with deterministic actions (recurrent policies too: each row carries its
    own LSTM state), and its sampled actions (``PATH@sampled``), each row drawing from its own copy of
    the torch generator state the single path seeds per episode (:func:`_sample_rows`). Not batched (one
    episode at a time, as before): rule agents and RLlib checkpoints (no batched action here), sampled
    actions of recurrent and maskable policies (their draw needs the LSTM state or the mask of one
    row), a target-choice policy run in a target+torque env (its
    action conversion is per-env), and with ``exact_actions`` a recurrent policy with continuous actions
    (its rows would need the LSTM state split per row to predict alone; not done)."""
    from planetnav_train.sb3 import SB3Agent

    if not isinstance(agent, SB3Agent):
        return f"{type(agent).__name__} has no batched action"
    if not agent.deterministic and not _samples_per_row(agent.model):
        return f"sampled actions of {type(agent.model).__name__} are drawn one episode at a time"
    if agent._as_target_torque:
        return "a target-choice policy in a target+torque env converts its action per env"
    if exact_actions and not _argmax_actions(agent.model) and hasattr(agent.model.policy, "lstm_actor"):
        return "a recurrent policy with continuous actions predicts exactly only one episode at a time"
    return None


def _samples_per_row(model: Any) -> bool:
    """Whether ``model``'s sampled actions can be drawn row by row here (:func:`_sample_rows`): its
    ``predict`` is SB3's own (DQN's draws its epsilon-greedy exploration from numpy, RecurrentPPO's
    needs its LSTM state, MaskablePPO's the row's mask) and its policy has an action distribution (an
    actor-critic's, or an off-policy actor's such as SAC's; TD3's actor is deterministic)."""
    from stable_baselines3.common.base_class import BaseAlgorithm

    if type(model).predict is not BaseAlgorithm.predict or hasattr(model.policy, "lstm_actor"):
        return False
    policy, actor = model.policy, getattr(model.policy, "actor", None)
    return hasattr(policy, "get_distribution") or hasattr(actor, "get_action_dist_params")


def _argmax_actions(model: Any) -> bool:
    """Whether ``model``'s deterministic action is an argmax (Discrete / MultiDiscrete): unchanged by the
    last-bit rounding of a batched forward pass, so its rows predict in one call (module docstring)."""
    from gymnasium import spaces

    return isinstance(model.action_space, (spaces.Discrete, spaces.MultiDiscrete))


class _RecordingRows(RowsWrapper):
    """The vector env's rows, recording every environment step of the rows stepped: the per-step values
    :func:`_episode` collects from ``info`` (position error and 1-sigma [km], velocity error [km/s],
    measured, slewing), the environment's reward summed in step order (as ``_episode`` sums it: the same
    float64 additions), and how each row's last step ended. Innermost under the recipe's layers, so action
    repeat's held steps are recorded one by one."""

    def __init__(self, inner: VectorRows, max_steps: int, on_steps: Callable[[int], None]) -> None:
        super().__init__(inner)
        self.venv = inner.venv
        n = self.num_rows
        self.steps = np.zeros(n, dtype=np.int64)
        self.err = np.zeros((n, max_steps))
        self.sig = np.zeros((n, max_steps))
        self.vel = np.zeros((n, max_steps))
        self.measured_count = np.zeros(n, dtype=np.int64)
        self.slews = np.zeros(n, dtype=np.int64)
        self.ret = np.zeros(n)
        self.terminated = np.zeros(n, dtype=bool)
        self.on_steps = on_steps

    def step_rows(self, actions: Any, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # One decision; each of its physics steps recorded as it happens (decision_steps > 1 holds it).
        reward, terminated, truncated = self.venv.step_rows(actions, active, on_step=self._record)
        rows = np.flatnonzero(active)
        self.ret[rows] += reward[rows]
        self.terminated[rows] = terminated[rows]
        return reward, terminated, truncated

    def _record(self, stepped: np.ndarray) -> None:
        rows = np.flatnonzero(stepped)
        info = self.venv.info_arrays()
        k = self.steps[rows]
        if k.size and k.max() >= self.err.shape[1]:
            raise RuntimeError(f"a row ran past the episode length {self.err.shape[1]} without ending")
        self.err[rows, k] = info["pos_err_km"][rows]
        self.sig[rows, k] = info["pos_sigma_km"][rows]
        self.vel[rows, k] = info["vel_err_km_s"][rows]
        self.measured_count[rows] += info["measured"][rows]
        self.slews[rows] += info["slewing"][rows]
        self.steps[rows] += 1
        self.on_steps(len(rows))


def _batched_episodes(
    agent: Any,
    env_cfg: EnvConfig,
    seeds: Sequence[int],
    on_steps: Callable[[int], None],
    exact_actions: bool = True,
) -> list[dict[str, Any]]:
    """One episode per seed of the SB3 model behind ``agent`` (:func:`batch_reason` is None), the seeds
    as rows of one :class:`~planetnav_env.envs.vector_env.PlanetNavVectorEnv`: one ``model.predict`` per
    decision for all rows, the training recipe's layers (the model's features) over the rows, in the
    env's decision interface, as :func:`planetnav_train.envs.make_training_env` stacks them (without the
    pointing shaping: evaluation reports the environment's own reward, as the single-env path does).
    ``exact_actions``: a continuous policy predicts row by row (module docstring).
    Returns :func:`_episode`'s dicts; ``seconds`` is the batch's wall time over its rows."""
    from planetnav_env.envs.vector_env import PlanetNavVectorEnv

    n = len(seeds)
    venv = PlanetNavVectorEnv(n, env_cfg)  # stepped by step_rows only: no autoreset happens
    rec = _RecordingRows(VectorRows(venv), env_cfg.episode_steps, on_steps)
    options = TrainingOptions(features=agent.features.features if agent.features is not None else ())
    rows = options.stack(rec)
    model = agent.model
    import torch

    # One torch thread: the batch's products are small (100 rows x a 64-unit layer), and with two threads
    # on this 2-core machine the second one's spin-waiting made each predict 10x slower (7 ms per linear
    # layer for 8 rows, profiled; benchmarks/bench_eval.py).
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        per_row = exact_actions and not _argmax_actions(model)
        return _run_rows(rows, rec, venv, model, n, seeds, per_row, sampled=not agent.deterministic)
    finally:
        torch.set_num_threads(threads)
        venv.close()


def _predict_each_row(policy: Any, obs: np.ndarray) -> np.ndarray:
    """Deterministic actions of a continuous SB3 ``policy`` for the rows of ``obs``, each row's forward
    pass on that row alone (the tensor ``policy.predict(obs[r])`` builds: the single path's arithmetic);
    ``predict``'s once-per-call work (eval mode, ``no_grad``, the Box post-processing, elementwise and so
    the same on a stack) done once for all rows. ``tests/train/test_eval_batched.py`` checks it equals the
    single path's actions."""
    import torch

    policy.set_training_mode(False)
    with torch.no_grad():
        parts = [policy._predict(policy.obs_to_tensor(row)[0], deterministic=True) for row in obs]
    return _as_env_actions(policy, torch.cat(parts))


def _as_env_actions(policy: Any, actions: Any) -> np.ndarray:
    """A stack of policy outputs (a torch tensor, one row per env row) as ``BasePolicy.predict`` returns
    them after its forward pass: numpy, reshaped to the action space, Box actions unscaled or clipped."""
    from gymnasium import spaces

    out = actions.cpu().numpy().reshape((-1, *policy.action_space.shape))
    if isinstance(policy.action_space, spaces.Box):
        if policy.squash_output:
            return policy.unscale_action(out)
        return np.clip(out, policy.action_space.low, policy.action_space.high)
    return out


def _seeded_states(seeds: Sequence[int]) -> list[Any]:
    """Per seed, the torch CPU generator state ``torch.manual_seed(seed)`` sets (what the single path's
    ``SB3Agent.reset(seed)`` does before a sampled episode)."""
    import torch

    return [torch.Generator().manual_seed(int(s)).get_state() for s in seeds]


def _sample_rows(
    policy: Any, obs: np.ndarray, states: list[Any], active: np.ndarray, per_row: bool
) -> np.ndarray:
    """Sampled actions of SB3 ``policy`` for the ``active`` rows of ``obs``, row ``r`` drawing from its own
    torch generator state ``states[r]`` (updated in place), so that each row draws what the single path
    draws from the global generator seeded with its episode's seed. Inactive rows draw nothing (their
    episode has ended; their entry repeats an active row's action and is never applied).

    ``per_row``: each row's forward pass and draw is the single path's very call (``policy._predict``)
    under the row's state. Otherwise one forward pass serves all rows and each row draws from its slice
    of the distribution as torch's ``sample`` / ``rsample`` does (:func:`_draw`). The batched forward
    pass rounds the last bits of the distribution's parameters differently: a discrete draw changes only
    when its uniform falls within that rounding of a cumulative probability; a continuous action carries
    them (``exact_actions=False``, as the argmax rows do). The global generator is restored on return;
    :func:`_run_rows` leaves it where the single path does."""
    import torch

    rows = np.flatnonzero(active)
    saved = torch.get_rng_state()
    policy.set_training_mode(False)
    parts: dict[int, Any] = {}
    try:
        with torch.no_grad():
            if per_row:
                for r in rows:
                    torch.set_rng_state(states[r])
                    parts[r] = policy._predict(policy.obs_to_tensor(obs[r])[0], deterministic=False)
                    states[r] = torch.get_rng_state()
            else:
                dist = _distribution(policy, policy.obs_to_tensor(obs)[0])
                for r in rows:
                    torch.set_rng_state(states[r])
                    parts[r] = _draw(dist, r)
                    states[r] = torch.get_rng_state()
    finally:
        torch.set_rng_state(saved)
    filler = parts[int(rows[0])]
    return _as_env_actions(policy, torch.cat([parts.get(r, filler) for r in range(len(obs))]))


def _distribution(policy: Any, obs: Any) -> Any:
    """The SB3 action distribution of ``policy`` for the batch ``obs`` (a tensor): an actor-critic policy's
    ``get_distribution``, or an off-policy actor's (SAC) distribution from its parameters (the two kinds
    :func:`_samples_per_row` admits)."""
    if hasattr(policy, "get_distribution"):
        return policy.get_distribution(obs)
    mean, log_std, kwargs = policy.actor.get_action_dist_params(obs)
    return policy.actor.action_dist.proba_distribution(mean, log_std, **kwargs)


def _draw(dist: Any, r: int) -> Any:
    """Row ``r``'s sample of the batched SB3 distribution ``dist`` from torch's global generator, drawn
    as the distribution draws for a 1-row batch: ``Categorical.sample`` (one ``torch.multinomial`` of the
    row's probabilities) or ``Normal.rsample`` (``loc + eps * scale``, then ``tanh`` when squashed)."""
    import torch
    from stable_baselines3.common.distributions import (
        CategoricalDistribution,
        DiagGaussianDistribution,
        SquashedDiagGaussianDistribution,
    )

    inner = dist.distribution
    if isinstance(dist, CategoricalDistribution):
        return torch.multinomial(inner.probs[r : r + 1], 1, True).T.reshape(1)
    if isinstance(dist, DiagGaussianDistribution):  # the squashed one is a subclass
        loc, scale = inner.loc[r : r + 1], inner.scale[r : r + 1]
        action = loc + torch.empty(loc.shape, dtype=loc.dtype).normal_() * scale
        return torch.tanh(action) if isinstance(dist, SquashedDiagGaussianDistribution) else action
    raise TypeError(f"no row-wise draw for {type(dist).__name__}")


def _run_rows(
    rows: Any,
    rec: _RecordingRows,
    venv: Any,
    model: Any,
    n: int,
    seeds: Sequence[int],
    per_row: bool,
    sampled: bool = False,
) -> list[dict[str, Any]]:
    """The loop of :func:`_batched_episodes`: reset every row to its seed, one decision for all rows per
    step (``per_row``: ``model.predict`` on each running row alone, as the single-env path calls it;
    ``sampled``: each running row's draw from its own generator state, :func:`_sample_rows`) until every
    row's episode has ended, then each row's :func:`_episode_record`."""
    from gymnasium import spaces

    recurrent = hasattr(model.policy, "lstm_actor")
    t0 = time.perf_counter()
    rows.reset_rows(np.ones(n, dtype=bool), [int(s) for s in seeds])
    running = np.ones(n, dtype=bool)
    state: Any = None
    first = True
    states = _seeded_states(seeds) if sampled else []
    # Sampled rows share one forward pass where the argmax rows do (a Discrete policy; a Box one unless
    # per_row), and _draw knows the distribution; else each row runs the single path's call.
    sample_per_row = per_row or not isinstance(model.action_space, (spaces.Discrete, spaces.Box))
    while running.any():
        obs = rows.observations()
        # Every row is predicted (the finished ones too: their stale actions are never applied), so the
        # batch keeps one shape; a recurrent policy carries one LSTM state per row from episode_start.
        # Sampled rows draw only while running, so each row's stream is its episode's.
        if sampled:
            action = _sample_rows(model.policy, obs, states, running, sample_per_row)
        elif per_row:
            action = _predict_each_row(model.policy, obs)
        elif recurrent:
            action, state = model.predict(
                obs, state=state, episode_start=np.full(n, first), deterministic=True
            )
        else:
            action, _ = model.predict(obs, deterministic=True)
        first = False
        _, terminated, truncated = rows.step_rows(action, running)
        running &= ~(terminated | truncated)
    if sampled:
        import torch

        # The global generator as the single path leaves it: after the last seed's episode. A learning
        # curve scored during training then leaves the trainer's own draws as they were.
        torch.set_rng_state(states[-1])
    seconds = (time.perf_counter() - t0) / n
    runs = []
    for r in range(n):
        k = int(rec.steps[r])
        err = rec.err[r, :k].copy()
        record = _episode_record(
            err, rec.sig[r, :k].copy(), rec.vel[r, :k], int(rec.measured_count[r]), int(rec.slews[r]),
            float(rec.ret[r]), bool(rec.terminated[r]), seconds, venv.info_row(r),
        )  # fmt: skip
        runs.append(record)
    return runs


def _padded_mean(curves: Sequence[np.ndarray]) -> np.ndarray:
    """Mean over curves of unequal length, step by step (the shorter ones padded with NaN)."""
    n = max(len(c) for c in curves)
    out = np.full((len(curves), n), np.nan)
    for i, c in enumerate(curves):
        out[i, : len(c)] = c
    return np.nanmean(out, axis=0)


def evaluate_agent(
    spec: str,
    env_cfg: EnvConfig,
    episodes: int,
    seed: int,
    progress: bool = True,
    batched: bool = True,
    batch_rows: int = EVAL_BATCH_ROWS,
    exact_actions: bool = True,
) -> EvalResult:
    """Run agent ``spec`` (name, ``name:key=value,...`` or model path) on seeds ``seed, seed+1, ...``.

    ``batched``: an agent that can (:func:`batch_reason`) plays its seeds as rows of the native vector
    env, ``batch_rows`` seeds per batch (:func:`_batched_episodes`); the others, or ``batched=False``,
    play one episode at a time. Both give the same per-episode results; ``metrics["batched"]`` says which
    ran, ``metrics["batch_fallback"]`` why an agent did not batch. ``exact_actions`` (default): a
    continuous policy's predict runs row by row, so its results equal the single env's too (module
    docstring); False: one predict for all rows (faster; equal to float rounding only).

    Raises :class:`planetnav_agents.NotApplicableError` when the agent cannot act in this environment.
    """
    from tqdm.auto import tqdm

    from planetnav_env.envs.env import PlanetNavEnv

    if isinstance(batch_rows, bool) or not isinstance(batch_rows, (int, np.integer)) or batch_rows < 1:
        raise ValueError(f"batch_rows must be a positive integer, got {batch_rows!r}")
    reason = not_applicable(spec, env_cfg)
    if reason:
        raise NotApplicableError(reason)
    if acts_at_physics_step(spec):
        env_cfg = env_cfg.at_physics_step()  # same physics and objective, the rule agents' interface
    # Only the idle agent gets the extra "camera off" action: the others keep the trained action space.
    overrides = {"idle_action": True} if requires_idle_action(spec) else {}
    env = PlanetNavEnv(env_cfg, **overrides)
    agent = make_agent(spec, env)
    name = getattr(agent, "name", spec)
    bar = tqdm(
        total=episodes * env_cfg.episode_steps,
        desc=f"eval {name}",
        unit="step",
        disable=not progress,
        leave=False,
    )
    fallback = batch_reason(agent, exact_actions) if batched else "batched=False"
    if fallback is None:
        runs = []
        for start in range(0, episodes, batch_rows):
            seeds = range(seed + start, seed + min(start + batch_rows, episodes))
            runs += _batched_episodes(agent, env_cfg, seeds, bar.update, exact_actions)
    else:
        runs = [_episode(agent, env, seed + i, lambda: bar.update(1)) for i in range(episodes)]
    bar.close()
    env.close()
    final = np.array([r["pos_err"][-1] for r in runs])
    per_episode = np.array([np.mean(r["pos_err"]) for r in runs])
    # The filter's own 1-sigma varies far less from seed to seed than the error drawn around it, so
    # paired differences of it resolve what the error's cannot.
    per_episode_sigma = [float(np.mean(r["pos_sigma"])) for r in runs]
    ci = mean_ci(per_episode)
    objective = np.array([r["objective"] for r in runs])
    obj_ci = mean_ci(objective)
    metrics = {
        "episodes": episodes,
        "seed": seed,
        "noise_streams": env_cfg.noise_streams,
        "mean_pos_err_km": ci.mean,
        "mean_pos_err_ci95_km": [ci.low, ci.high],
        "final_pos_err_km": float(np.mean(final)),
        "final_pos_err_std_km": float(np.std(final)),
        "final_pos_err_ci95_km": [mean_ci(final).low, mean_ci(final).high],
        "final_pos_sigma_km": float(np.mean([r["pos_sigma"][-1] for r in runs])),
        "mean_pos_sigma_km": float(np.mean(per_episode_sigma)),
        "mean_vel_err_km_s": float(np.mean([r["mean_vel_err_km_s"] for r in runs])),
        "measured_fraction": float(np.mean([r["measured_fraction"] for r in runs])),
        "slews": float(np.mean([r["slews"] for r in runs])),
        "return": float(np.mean([r["return"] for r in runs])),
        "diverged": int(sum(r["diverged"] for r in runs)),
        # Wall seconds per episode; batched, a batch's wall time over its rows.
        "seconds_per_episode": float(np.mean([r["seconds"] for r in runs])),
        "batched": fallback is None,
        **({"exact_actions": bool(exact_actions)} if fallback is None else {}),
        # Why a saved model did not batch (rule agents never do: no note for them).
        **({"batch_fallback": fallback} if fallback and batched and hasattr(agent, "model") else {}),
        "per_episode_mean_pos_err_km": per_episode.tolist(),
        "per_episode_mean_pos_sigma_km": per_episode_sigma,
        # Scenario objective J [km] per episode (episode_objective): info["objective"] at the end on an
        # operations scenario, else the episode's mean position error.
        "objective_kind": "operations J" if env_cfg.operations is not None else "mean position error",
        "objective_mean": obj_ci.mean,
        "objective_ci95": [obj_ci.low, obj_ci.high],
        "per_episode_objective": objective.tolist(),
    }
    return EvalResult(
        name=name,
        metrics=metrics,
        pos_err_curve=_padded_mean([r["pos_err"] for r in runs]),
        pos_sigma_curve=_padded_mean([r["pos_sigma"] for r in runs]),
        episode_mean_err=per_episode,
        seeds=tuple(range(seed, seed + episodes)),
    )


def add_paired(results: Sequence[EvalResult], reference: str) -> EvalResult | None:
    """Adds ``metrics["vs_reference"]`` (mean of the per-seed differences agent - reference of the mean
    position error [km] with its paired 95 % t-interval, and the ratio of the means) to every agent that
    ran on the reference's seeds, and the same paired difference of the objective J [km]
    (``mean_objective_diff_km``, ``objective_ci95_km``; :func:`episode_objective`). The reference is the
    result whose name is ``reference`` (or starts with ``reference:``); returns it,
    or None when it did not run."""
    ref = next(
        (r for r in results if r.ran and (r.name == reference or r.name.startswith(reference + ":"))), None
    )
    if ref is None:
        return None
    for r in results:
        if not r.ran or r.seeds != ref.seeds:
            continue
        d = paired_difference(r.episode_mean_err, ref.episode_mean_err)
        ds = paired_difference(
            r.metrics["per_episode_mean_pos_sigma_km"], ref.metrics["per_episode_mean_pos_sigma_km"]
        )
        r.metrics["vs_reference"] = {
            "reference": ref.name,
            "mean_diff_km": d.mean,
            "ci95_km": [d.low, d.high],
            "ratio": r.metrics["mean_pos_err_km"] / ref.metrics["mean_pos_err_km"],
            "outside_noise": d.excludes_zero(),
            "mean_sigma_diff_km": ds.mean,
            "sigma_ci95_km": [ds.low, ds.high],
        }
        if "per_episode_objective" in r.metrics and "per_episode_objective" in ref.metrics:
            do = paired_difference(r.metrics["per_episode_objective"], ref.metrics["per_episode_objective"])
            r.metrics["vs_reference"].update(
                {
                    "mean_objective_diff_km": do.mean,
                    "objective_ci95_km": [do.low, do.high],
                    "objective_outside_noise": do.excludes_zero(),
                }
            )
    return ref


def compare_agents(
    specs: Sequence[str],
    env_cfg: EnvConfig,
    episodes: int,
    seed: int,
    progress: bool = True,
    reference: str = REFERENCE,
) -> list[EvalResult]:
    """Evaluate each agent on the same seeds (so the same initial states and estimate errors); agents that
    cannot act in this environment are kept as skipped rows with the reason; paired differences against
    ``reference`` (see :func:`add_paired`)."""
    results = []
    for s in specs:
        try:
            results.append(evaluate_agent(s, env_cfg, episodes, seed, progress))
        except NotApplicableError as exc:
            results.append(_skipped(str(s), str(exc)))
    add_paired(results, reference)
    return results


def results_json(results: Sequence[EvalResult]) -> dict[str, Any]:
    """``{"agents": {name: metrics}, "skipped": {name: reason}}`` (names made unique if two agents share
    one)."""
    out: dict[str, Any] = {}
    skipped: dict[str, str] = {}
    for r in results:
        if not r.ran:
            skipped[r.name] = str(r.skipped)
            continue
        key, k = r.name, 2
        while key in out:
            key, k = f"{r.name}#{k}", k + 1
        out[key] = r.metrics
    return {"agents": out, "skipped": skipped}


def evaluation_env(env_cfg: EnvConfig, episode_steps: int | None, noise_streams: str | None) -> EnvConfig:
    """``env_cfg`` with the evaluation's overrides of the episode length and the noise streams (None:
    keep the env's own)."""
    overrides: dict[str, Any] = {}
    if episode_steps:
        overrides["episode_steps"] = episode_steps
    if noise_streams:
        overrides["noise_streams"] = noise_streams
    return EnvConfig.from_dict(env_cfg.to_dict(), **overrides) if overrides else env_cfg


DEFAULT_SWEEP_PERIODS = (10, 20, 30, 60, 120, 240)
DEFAULT_SWEEP_CYCLES = ("0-1", "0-2", "1-2", "0-1-2", "0-2-1")


def sweep_periodic(
    env_cfg: EnvConfig,
    periods: Sequence[int],
    cycles: Sequence[str],
    episodes: int,
    seed: int,
    progress: bool = True,
) -> list[EvalResult]:
    """Every ``periodic:period=P,cycle=C`` on the same seeds, best (lowest mean error) first, with paired
    differences against the best."""
    specs = [f"periodic:period={p},cycle={c}" for c in cycles for p in periods]
    results = [evaluate_agent(s, env_cfg, episodes, seed, progress) for s in specs]
    results.sort(key=lambda r: r.metrics["mean_pos_err_km"])
    add_paired(results, results[0].name)
    return results
