"""Diagnosis of a trained learner on a v3 task: what it does, beside the blind zero and uniform random on
the same evaluation seeds.

Train and save one first (the suite's learner run with ``--save-model``):

    python -m planetnav_train.suite.v3 learners --task RandomCruise-Target-v3 --seed 0 --save-model M.zip
    python research/tasks_v3/diagnose_learners.py --task RandomCruise-Target-v3 --model M.zip

``--reference SPEC`` adds a rule agent (e.g. ``greedy:bias=photometric``), played in the rules' own
interface and sampled at the decision boundaries.

Per policy: J [km]; fixes per target per episode and their mean normalized NIS (the filter's own
consistency per beacon); on target tasks, how often the action changes between decisions and the action
frequencies in each third of the episode; on the torque task, the mean |torque| command, momentum dumps
and wheel-saturation time per episode.
"""

from __future__ import annotations

import argparse

import numpy as np

from planetnav_env.core import layout as L
from planetnav_train.suite import v3


def describe(name, cfg, out: v3.Rollout) -> None:
    f = out.final
    t = cfg.n_targets
    fixes = f[:, L.F_RES_LOG : L.F_RES_LOG + t]
    nis = f[:, L.F_RES_LOG + L.MAX_TARGETS : L.F_RES_LOG + L.MAX_TARGETS + t] / np.maximum(fixes, 1)
    names = [*cfg.planets, *cfg.pulsars]
    print(f"{name}: J {out.objective.mean():.1f} km")
    print(
        "   fixes / episode: " + ", ".join(f"{n} {m:.1f}" for n, m in zip(names, fixes.mean(0), strict=True))
    )
    print("   mean NIS / dof:  " + ", ".join(f"{n} {m:.2f}" for n, m in zip(names, nis.mean(0), strict=True)))
    if cfg.operations is not None:  # J = the deadline terms + w x delta-v lost
        w = cfg.operations.cost_weight
        dv = f[:, L.F_DV_LOST]
        print(f"   delta-v lost {dv.mean():.2f} m/s (w x it {w * dv.mean():.1f} km), deadline terms "
              f"{(f[:, L.F_OBJECTIVE] - w * dv).mean():.1f} km")  # fmt: skip
    a = out.actions  # (D, N[, 3])
    if cfg.action_mode == "torque":
        print(
            f"   mean |u| {np.abs(a).mean():.3f}; dumps / episode {f[:, L.F_DUMPS].mean():.2f}; "
            f"saturated {f[:, L.F_SAT_S].mean():.0f} s / episode"
        )
        return
    switch = (a[1:] != a[:-1]).mean()
    print(f"   action changes at {switch:.1%} of decisions")
    for k, part in enumerate(np.array_split(a, 3)):
        freq = np.bincount(part.ravel().astype(int), minlength=cfg.n_target_actions) / part.size
        print(f"   third {k + 1}: " + " ".join(f"{x:.2f}" for x in freq))


def rule_rollout(cfg, spec: str, seeds: range) -> v3.Rollout:
    """Rule agent ``spec`` played in the rules' interface (every physics step), one episode per seed, as a
    :class:`v3.Rollout`: its J per episode, each episode's final core row, and its choices sampled at the
    task's decision boundaries ((D, N), as a learner's)."""
    from planetnav_agents import make_agent, requires_idle_action
    from planetnav_env.envs.env import PlanetNavEnv
    from planetnav_train.evaluate import episode_objective

    if cfg.action_mode != "target":
        raise SystemExit(
            f"--reference: the rules' choices are tabled on target tasks only, not {cfg.action_mode!r}"
        )
    env = PlanetNavEnv(cfg.at_physics_step(), **({"idle_action": True} if requires_idle_action(spec) else {}))
    agent = make_agent(spec, env)
    objective, final, actions = [], [], []
    for seed in seeds:
        agent.reset(seed=seed)
        obs, info = env.reset(seed=seed)
        err, chosen = [], []
        while True:
            a = agent.act(obs, info)
            obs, _, terminated, truncated, info = env.step(a)
            err.append(info["pos_err_km"])
            chosen.append(int(a))
            if terminated or truncated:
                break
        objective.append(episode_objective(info, np.asarray(err)))
        final.append(env.core.f[0].copy())
        actions.append(chosen[:: cfg.decision_steps][: cfg.episode_decisions])
    return v3.Rollout(np.asarray(objective), final=np.asarray(final), actions=np.asarray(actions).T)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--task", required=True)
    ap.add_argument("--model", required=True, help="SB3 zip from `learners --save-model`")
    ap.add_argument("--algo", default="ppo", choices=sorted(v3.LEARNERS))
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--reference", action="append", default=[], help="also a rule agent's spec (repeatable)")
    args = ap.parse_args()
    import stable_baselines3

    cfg = v3.eval_config(f"planetnav/{args.task}")
    seeds = range(v3.EVAL_SEED, v3.EVAL_SEED + args.episodes)
    cls_name, acting = v3.LEARNERS[args.algo]
    model = getattr(stable_baselines3, cls_name).load(args.model, device="cpu")
    blind = v3.read_json(v3.BLIND_FILE)["tasks"][args.task]
    zero = v3.policy_from_record(blind["winner"], blind["policies"][blind["winner"]])
    if cfg.action_mode == "torque":
        uniform = v3.BlindTorques("uniform", np.zeros((cfg.episode_decisions, 3)), 1.0)
    else:
        n_a = cfg.n_target_actions
        uniform = v3.BlindTargets("uniform", np.full((cfg.episode_decisions, n_a), 1.0 / n_a))
    policies = {
        f"{cls_name} ({acting})": v3._policy_fn(model, [], acting == "deterministic"),
        f"{cls_name} (argmax / mean)": v3._policy_fn(model, [], True),
        f"blind zero ({blind['winner']})": zero,
        "uniform random": uniform,
    }
    for name, pol in policies.items():
        describe(name, cfg, v3.roll_out(cfg, pol, seeds, final=True, actions=True))
    for spec in args.reference:
        describe(f"rule {spec}", cfg, rule_rollout(cfg, spec, seeds))


if __name__ == "__main__":
    main()
