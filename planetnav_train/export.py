"""Policy-only export of a saved Stable-Baselines3 / sb3-contrib model (the suite's shipped baselines
under 1 MB; format and loader: :mod:`planetnav_train.policy_only`).

:func:`export_policy` loads a model ``.zip``, keeps the tensors its deterministic actions use (the actor;
DQN's online Q-network; RecurrentPPO's actor LSTM, policy MLP and action net: :data:`ACTING_RULES
<planetnav_train.policy_only.ACTING_RULES>`) in their own dtype, with the policy class, its constructor
arguments, the spaces and a masking MaskablePPO's ``observation_layout``, and drops the critics, target
networks, optimizer states and every other training-only attribute (an off-policy model's zip has no
replay buffer; it is saved apart, if at all). It then checks its own output: the file is read back
through the loader, the rebuilt policy must have the source policy's architecture (every parameter name
and shape, the dropped ones included), and its deterministic actions must equal the source model's on
:data:`CHECK_ROWS` observations sampled from the observation space (a recurrent policy: over
:data:`CHECK_STEPS` steps carrying its state, with episode starts).

Sizes (``bytes``): ``python train.py suite-sizes`` prints them; ``tests/train/test_export.py`` bounds them.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_train import policy_only as po

#: Observations sampled (seeded) from the observation space for the export's self-check.
CHECK_ROWS = 16
#: Steps of the recurrent self-check (rows 0 and 1 start a new episode half-way).
CHECK_STEPS = 6


def policy_kwargs_of(model: Any) -> dict[str, Any]:
    """The keyword arguments the model's policy class is rebuilt with: what SB3's ``BasePolicy.save``
    records (``_get_constructor_parameters``), updated with the algorithm's ``policy_kwargs``, which
    carry what some of those lists miss (sb3-contrib's recurrent policy records no ``lstm_hidden_size``;
    SB3's actor-critic no ``share_features_extractor``). Spaces and the learning-rate schedule are not
    arguments here (the file stores the spaces; the loader gives a schedule that is never used)."""
    kwargs = dict(model.policy._get_constructor_parameters())
    kwargs.update(model.policy_kwargs or {})
    for key in ("observation_space", "action_space", "lr_schedule"):
        kwargs.pop(key, None)
    return kwargs


def _stack(samples: list[Any]) -> Any:
    """Samples of a space stacked into one batch (a Dict space: per key)."""
    if isinstance(samples[0], dict):
        return {k: np.stack([s[k] for s in samples]) for k in samples[0]}
    return np.stack([np.asarray(s) for s in samples])


def check_same_actions(source: Any, export: Any, seed: int = 0) -> int:
    """Raise ``RuntimeError`` unless ``export`` (a :class:`~planetnav_train.policy_only.PolicyOnlyModel`)
    acts exactly as ``source`` (the full model) on :data:`CHECK_ROWS` observations sampled from the
    observation space with ``seed`` (a recurrent policy: over :data:`CHECK_STEPS` steps, states carried,
    episode starts at step 0 and for rows 0-1 half-way). Returns how many actions were compared."""
    space = source.observation_space
    space.seed(seed)
    recurrent = hasattr(source.policy, "lstm_actor")
    steps = CHECK_STEPS if recurrent else 1
    s_state = e_state = None
    compared = 0
    for t in range(steps):
        obs = _stack([space.sample() for _ in range(CHECK_ROWS)])
        start = np.full(CHECK_ROWS, t == 0)
        if t == steps // 2 and recurrent:
            start[:2] = True
        a, s_state = source.predict(obs, state=s_state, episode_start=start, deterministic=True)
        b, e_state = export.predict(obs, state=e_state, episode_start=start, deterministic=True)
        if not np.array_equal(a, b):
            raise RuntimeError(f"the policy-only export acts differently at step {t}: {a!r} vs {b!r}")
        if recurrent and not all(np.array_equal(x, y) for x, y in zip(s_state, e_state, strict=True)):
            raise RuntimeError(f"the policy-only export's LSTM state differs at step {t}")
        compared += int(np.size(a))
    return compared


def export_policy(source: str | Path, dest: str | Path, algo: str) -> Path:
    """Write the policy-only export of the SB3 model ``source`` (a ``.zip`` or a run directory) of algorithm
    ``algo`` (a name in :data:`planetnav_train.sb3.ALGORITHMS`; required: an A2C zip also loads as PPO, so
    trying each algorithm would misname it) to ``dest``, then check it (module docstring).

    Raises ``ValueError`` naming the value that cannot be stored (an exotic space or constructor
    argument, a parameter no rule covers) and ``RuntimeError`` when the read-back check fails; a failed
    export leaves no file at ``dest``."""
    from planetnav_train.sb3 import load_model, resolve_model_path

    src = resolve_model_path(source)
    name = str(algo).lower()
    model = load_model(src, name)  # ValueError naming an unknown algorithm
    policy = model.policy
    full = policy.state_dict()
    kept, dropped = po.split_acting(policy, list(full))
    arrays: dict[str, np.ndarray] = {}
    meta = {
        "format": po.FORMAT,
        "format_version": po.FORMAT_VERSION,
        "algorithm": name,
        "policy_class": po.class_path(type(policy)),
        "policy_kwargs": po.encode_value(policy_kwargs_of(model), "policy_kwargs"),
        "observation_space": po.encode_space(model.observation_space, "observation_space", arrays),
        "action_space": po.encode_space(model.action_space, "action_space", arrays),
        "observation_layout": getattr(model, "observation_layout", None),
        "parameters": {k: {"shape": list(full[k].shape), "dtype": str(full[k].dtype)} for k in kept},
        "dropped_parameters": len(dropped),
        "source": {"file": src.name, "bytes": src.stat().st_size, "sha256": _sha256(src)},
        "versions": _versions(),
    }
    for key in kept:
        arrays[f"params/{key}"] = full[key].detach().cpu().numpy()
    dest = Path(dest)
    po.write_archive(dest, meta, arrays)
    try:
        export = po.load_policy_only(dest)
        rebuilt = export.policy.state_dict()
        shapes = {k: tuple(v.shape) for k, v in full.items()}
        if {k: tuple(v.shape) for k, v in rebuilt.items()} != shapes:
            raise RuntimeError(
                f"{src}: the rebuilt {type(policy).__qualname__} has another architecture "
                f"(names/shapes {sorted(set(rebuilt) ^ set(full)) or 'differ'})"
            )
        check_same_actions(model, export)
    except Exception:
        dest.unlink(missing_ok=True)
        raise
    return dest


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _versions() -> dict[str, str]:
    """Versions of the packages the loader rebuilds the policy with (for a reader of the file)."""
    import stable_baselines3
    import torch

    out = {"stable_baselines3": stable_baselines3.__version__, "torch": torch.__version__}
    try:
        import sb3_contrib

        out["sb3_contrib"] = sb3_contrib.__version__
    except ImportError:
        pass
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m planetnav_train.export MODEL --algo ALGO [--out FILE]``: export one model, print both
    sizes in bytes."""
    import argparse

    ap = argparse.ArgumentParser(prog="python -m planetnav_train.export", description=main.__doc__)
    ap.add_argument("model", help="an SB3 model .zip or a run directory")
    ap.add_argument("--algo", required=True, help="its algorithm (ppo, dqn, sac, recurrent_ppo, ...)")
    ap.add_argument("--out", help="the export's path (default: MODEL's name with .policy.zip)")
    args = ap.parse_args(argv)
    from planetnav_train.sb3 import resolve_model_path

    src = resolve_model_path(args.model)
    dest = Path(args.out) if args.out else src.with_suffix(".policy.zip")
    export_policy(src, dest, args.algo)
    print(f"{src}: {src.stat().st_size:,} bytes -> {dest}: {dest.stat().st_size:,} bytes (policy-only)")
    return 0


__all__ = ["CHECK_ROWS", "CHECK_STEPS", "check_same_actions", "export_policy", "main", "policy_kwargs_of"]


if __name__ == "__main__":
    raise SystemExit(main())
