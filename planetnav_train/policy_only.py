"""Policy-only exports of Stable-Baselines3 models: the file format, and its loader.

A saved SB3 model (``model.zip``) holds everything training needs: the critics, target networks,
optimizer states. Acting needs only the policy's acting part (the actor; a DQN's online Q-network; a
recurrent policy's actor LSTM, policy MLP and action net). A *policy-only export* keeps just that, so that
a continuous-action baseline (SAC, TD3, TQC: 3.5-5.7 MB as full zips) or a recurrent one (about 8 MB) fits
the shipped baselines' size limit (:mod:`planetnav_train.shipped`). It is written by
:func:`planetnav_train.export.export_policy` and read by :func:`load_policy_only`.

The file is a zip (fixed timestamps: exporting the same model twice gives the same bytes) holding

- ``planetnav_policy.json`` (:data:`META_NAME`): the format and its version, the algorithm's name (a key of
  :data:`planetnav_train.sb3.ALGORITHMS`), the policy class and the keyword arguments it is rebuilt with
  (classes written as ``"module:qualname"``), the observation and action spaces, the
  ``observation_layout`` a masking MaskablePPO recorded (:mod:`planetnav_train.masking`; else null),
  the kept parameters' names, shapes and dtypes, and the source model's size and sha256;
- ``params/<name>.npy``: each kept tensor of the policy's ``state_dict``, in its own dtype (float32 as
  trained: nothing is rounded), and ``spaces/<name>.npy``: the bounds of Box spaces.

Nothing in it is unpickled. The loader rebuilds the SB3 policy class itself from the recorded keyword
arguments (no second implementation of any network) and loads the kept tensors into it; every kept tensor
must land on a parameter of the same shape and dtype, and every parameter left without one must be a
dropped (non-acting) one. The critics and target networks the constructor builds keep their random
initial values and are never used: deterministic actions go through the actor alone.
"""

from __future__ import annotations

import importlib
import io
import json
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

#: The metadata member of a policy-only export; its presence is what marks the format.
META_NAME = "planetnav_policy.json"
FORMAT = "planetnav-policy-only"
FORMAT_VERSION = 1
#: Zip members' timestamp (the zip format's earliest): the same export gives the same bytes, so sha256s.
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)
#: Modules a recorded class may come from (a class name read from a file is imported, so only these).
_CLASS_ROOTS = ("torch", "stable_baselines3", "sb3_contrib", "planetnav_train", "planetnav_env")

#: Which ``state_dict`` entries act, per policy family: (attribute that marks the family, kept names,
#: dropped names); a name covers itself and everything under it (``name.``). First match wins, so the
#: recurrent family comes before the other actor-critics. A parameter in neither list is refused
#: (:func:`split_acting`): exporting must never guess.
ACTING_RULES: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    # sb3-contrib RecurrentActorCriticPolicy (RecurrentPPO): the actor LSTM feeds the policy MLP.
    (
        "lstm_actor",
        (
            "features_extractor",
            "pi_features_extractor",
            "lstm_actor",
            "mlp_extractor.policy_net",
            "action_net",
            "log_std",
        ),
        ("vf_features_extractor", "lstm_critic", "critic", "mlp_extractor.value_net", "value_net"),
    ),
    # ActorCriticPolicy (PPO, A2C) and MaskableActorCriticPolicy (MaskablePPO). ``log_std`` (a Box
    # policy's Gaussian) is not used by deterministic actions; it is one small vector, kept so that
    # sampled actions work too.
    (
        "action_net",
        ("features_extractor", "pi_features_extractor", "mlp_extractor.policy_net", "action_net", "log_std"),
        ("vf_features_extractor", "mlp_extractor.value_net", "value_net"),
    ),
    # DQNPolicy: the online Q-network acts (argmax); its target copy only trains.
    ("q_net", ("q_net",), ("q_net_target",)),
    # SACPolicy, TD3Policy (TD3, DDPG), TQCPolicy: the actor acts; critics and targets only train.
    ("actor", ("actor",), ("actor_target", "critic", "critic_target")),
)


def _covered(key: str, names: tuple[str, ...]) -> bool:
    return any(key == n or key.startswith(n + ".") for n in names)


def acting_rule(policy: Any) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(kept names, dropped names) of :data:`ACTING_RULES` for ``policy``; ``ValueError`` naming its class
    when no rule applies."""
    for marker, keep, drop in ACTING_RULES:
        if getattr(policy, marker, None) is not None:
            return keep, drop
    raise ValueError(
        f"no policy-only rule for {type(policy).__module__}.{type(policy).__qualname__}: it has none of "
        f"{[r[0] for r in ACTING_RULES]}"
    )


def split_acting(policy: Any, keys: Any) -> tuple[list[str], list[str]]:
    """``keys`` of ``policy``'s ``state_dict`` split into (kept, dropped) by :func:`acting_rule`.

    Raises ``ValueError`` naming every key that is in neither list (an unknown part of the network is
    never silently dropped, nor silently kept)."""
    keep, drop = acting_rule(policy)
    kept = [k for k in keys if _covered(k, keep)]
    dropped = [k for k in keys if _covered(k, drop) and not _covered(k, keep)]
    unknown = sorted(set(keys) - set(kept) - set(dropped))
    if unknown:
        raise ValueError(
            f"{type(policy).__qualname__}: parameters {unknown} are neither acting ({list(keep)}) nor "
            f"training-only ({list(drop)}); refusing to guess"
        )
    return kept, dropped


# --- JSON encoding of the policy's constructor arguments and spaces -------------------------------------


def class_path(cls: type) -> str:
    """``"module:qualname"`` of a class."""
    return f"{cls.__module__}:{cls.__qualname__}"


def resolve_class(path: str) -> type:
    """The class named ``"module:qualname"`` (:func:`class_path`), imported only from
    :data:`_CLASS_ROOTS`; ``ValueError`` naming it otherwise."""
    module, _, qualname = str(path).partition(":")
    if not qualname or module.split(".")[0] not in _CLASS_ROOTS:
        raise ValueError(f"class {path!r}: expected 'module:qualname' under one of {list(_CLASS_ROOTS)}")
    obj: Any = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part, None)
        if obj is None:
            raise ValueError(f"class {path!r}: {module} has no {qualname}")
    if not isinstance(obj, type):
        raise ValueError(f"{path!r} is not a class")
    return obj


def encode_value(value: Any, where: str) -> Any:
    """A constructor argument as JSON data: plain values as they are, tuples as lists, classes as
    ``{"__class__": "module:qualname"}``. ``ValueError`` naming ``where`` for anything else (a
    function, an object: it could not be rebuilt without pickling)."""
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, type):
        return {"__class__": class_path(value)}
    if isinstance(value, (list, tuple)):
        return [encode_value(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, Mapping):
        if not all(isinstance(k, str) for k in value) or "__class__" in value:
            raise ValueError(f"{where}: a mapping with keys {list(value)} cannot be stored")
        return {k: encode_value(v, f"{where}.{k}") for k, v in value.items()}
    raise ValueError(f"{where} = {value!r} ({type(value).__name__}) cannot be stored in a policy-only export")


def decode_value(data: Any) -> Any:
    """The inverse of :func:`encode_value` (lists stay lists: SB3 accepts them wherever it takes tuples)."""
    if isinstance(data, list):
        return [decode_value(v) for v in data]
    if isinstance(data, dict):
        if set(data) == {"__class__"}:
            return resolve_class(data["__class__"])
        return {k: decode_value(v) for k, v in data.items()}
    return data


def encode_space(space: Any, name: str, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """A Gymnasium space as JSON data; a Box's bounds go to ``arrays`` (``spaces/<name>.low`` / ``.high``).
    Box, Discrete, MultiDiscrete, MultiBinary and Dict of these; ``ValueError`` naming any other."""
    from gymnasium import spaces

    if isinstance(space, spaces.Box):
        arrays[f"spaces/{name}.low"] = np.asarray(space.low)
        arrays[f"spaces/{name}.high"] = np.asarray(space.high)
        return {"type": "Box", "shape": list(space.shape), "dtype": str(space.dtype)}
    if isinstance(space, spaces.Discrete):
        return {"type": "Discrete", "n": int(space.n), "start": int(space.start)}
    if isinstance(space, spaces.MultiDiscrete):
        return {"type": "MultiDiscrete", "nvec": space.nvec.tolist(), "start": space.start.tolist(),
                "dtype": str(space.dtype)}  # fmt: skip
    if isinstance(space, spaces.MultiBinary):
        return {"type": "MultiBinary", "n": np.asarray(space.n).tolist()}
    if isinstance(space, spaces.Dict):
        return {
            "type": "Dict",
            "spaces": {k: encode_space(s, f"{name}.{k}", arrays) for k, s in space.items()},
        }
    raise ValueError(f"{name}: a {type(space).__name__} space cannot be stored in a policy-only export")


def decode_space(data: Mapping[str, Any], name: str, arrays: Mapping[str, np.ndarray]) -> Any:
    """The inverse of :func:`encode_space`."""
    from gymnasium import spaces

    kind = data.get("type")
    if kind == "Box":
        low, high = arrays[f"spaces/{name}.low"], arrays[f"spaces/{name}.high"]
        return spaces.Box(low=low, high=high, shape=tuple(data["shape"]), dtype=np.dtype(data["dtype"]))
    if kind == "Discrete":
        return spaces.Discrete(int(data["n"]), start=int(data["start"]))
    if kind == "MultiDiscrete":
        return spaces.MultiDiscrete(data["nvec"], dtype=np.dtype(data["dtype"]), start=data["start"])
    if kind == "MultiBinary":
        return spaces.MultiBinary(data["n"])
    if kind == "Dict":
        return spaces.Dict({k: decode_space(s, f"{name}.{k}", arrays) for k, s in data["spaces"].items()})
    raise ValueError(f"{name}: unknown space type {kind!r}")


# --- the file ---------------------------------------------------------------------------------------------


def write_archive(path: str | Path, meta: Mapping[str, Any], arrays: Mapping[str, np.ndarray]) -> Path:
    """Write ``meta`` (as :data:`META_NAME`) and ``arrays`` (each as ``<name>.npy``, no pickle) to the zip
    ``path``, members in name order with fixed timestamps."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w") as zf:
        info = zipfile.ZipInfo(META_NAME, date_time=_ZIP_TIME)
        info.compress_type = zipfile.ZIP_DEFLATED
        zf.writestr(info, json.dumps(meta, indent=1, sort_keys=True))
        for name in sorted(arrays):
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.ascontiguousarray(arrays[name]), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, buf.getvalue())
    return path


def is_policy_only(path: str | Path) -> bool:
    """Whether ``path`` is a policy-only export (a zip with :data:`META_NAME`), not a full SB3 model."""
    p = Path(path)
    if not p.is_file() or not zipfile.is_zipfile(p):
        return False
    with zipfile.ZipFile(p) as zf:
        return META_NAME in zf.namelist()


def read_archive(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(metadata, arrays) of a policy-only export; ``ValueError`` naming the file when it is not one or its
    format version is unknown."""
    p = Path(path)
    if not is_policy_only(p):
        raise ValueError(f"{p}: not a policy-only export (no {META_NAME} in a zip)")
    with zipfile.ZipFile(p) as zf:
        meta = json.loads(zf.read(META_NAME))
        arrays = {
            n[: -len(".npy")]: np.lib.format.read_array(io.BytesIO(zf.read(n)), allow_pickle=False)
            for n in zf.namelist()
            if n.endswith(".npy")
        }
    if meta.get("format") != FORMAT or meta.get("format_version") != FORMAT_VERSION:
        raise ValueError(
            f"{p}: format {meta.get('format')!r} version {meta.get('format_version')!r}; this loader reads "
            f"{FORMAT!r} version {FORMAT_VERSION}"
        )
    return meta, arrays


def _no_learning_rate(_progress_remaining: float) -> float:
    """The policy constructor's learning-rate schedule: it builds an optimizer that never steps."""
    return 0.0


def build_policy(meta: Mapping[str, Any], arrays: Mapping[str, np.ndarray], where: str = "export") -> Any:
    """The SB3 policy of a policy-only export (:func:`read_archive`), on the CPU in evaluation mode: its
    class rebuilt from the recorded keyword arguments, the kept tensors loaded.

    Raises ``ValueError`` naming ``where`` and the parameter when a kept tensor has no parameter of that
    name, another shape or another dtype, or when a parameter that acts was not in the file."""
    import torch

    arrays = dict(arrays)
    obs_space = decode_space(meta["observation_space"], "observation_space", arrays)
    act_space = decode_space(meta["action_space"], "action_space", arrays)
    cls = resolve_class(meta["policy_class"])
    policy = cls(obs_space, act_space, _no_learning_rate, **decode_value(meta["policy_kwargs"]))
    target = policy.state_dict()
    kept, dropped = split_acting(policy, list(target))
    state = {}
    for key in meta["parameters"]:
        arr = arrays.get(f"params/{key}")
        if arr is None:
            raise ValueError(f"{where}: parameter {key} is listed but not stored")
        if key not in target:
            raise ValueError(f"{where}: parameter {key} is not one of {cls.__qualname__}'s")
        tensor = torch.from_numpy(arr)
        if tensor.shape != target[key].shape or tensor.dtype != target[key].dtype:
            raise ValueError(
                f"{where}: parameter {key} is {tuple(tensor.shape)} {tensor.dtype}, the rebuilt "
                f"{cls.__qualname__} has {tuple(target[key].shape)} {target[key].dtype}"
            )
        state[key] = tensor
    missing = sorted(set(kept) - set(state))
    if missing:
        raise ValueError(f"{where}: acting parameters {missing} are not in the file")
    result = policy.load_state_dict(state, strict=False)
    # Left out may be only what the rule drops (a shared features extractor's critic alias included).
    left = sorted(set(result.missing_keys) - set(dropped))
    if result.unexpected_keys or left:
        raise ValueError(f"{where}: unexpected {result.unexpected_keys}, not loaded {left}")
    policy.to("cpu")
    policy.set_training_mode(False)
    return policy


class PolicyOnlyModel:
    """A policy-only export behind the part of an SB3 model's interface that acting uses
    (:class:`planetnav_train.sb3.SB3Agent`, :mod:`planetnav_train.evaluate`): ``policy``,
    ``observation_space``, ``action_space`` and ``predict``.

    ``algorithm``: the source model's algorithm name; ``observation_layout``: the layout a masking
    MaskablePPO recorded (its ``predict`` masks the unobservable targets from the observation, as
    :func:`planetnav_train.masking.masked_ppo_class`'s does); ``meta``: the file's metadata."""

    def __init__(self, policy: Any, meta: Mapping[str, Any], path: Path | None = None) -> None:
        self.policy = policy
        self.meta = dict(meta)
        self.path = path
        self.algorithm = str(meta["algorithm"])
        self.observation_space = policy.observation_space
        self.action_space = policy.action_space
        self.observation_layout: dict[str, Any] | None = meta.get("observation_layout")

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
        action_masks: np.ndarray | None = None,
    ) -> tuple[np.ndarray, Any]:
        """(actions, next recurrent state) as the source model's ``predict`` returns them: the same
        policy's ``predict`` on the same tensors. Sampled actions (``deterministic=False``) of a DQN are
        refused: its epsilon-greedy exploration is the algorithm's, not the policy's."""
        if not deterministic and self.algorithm == "dqn":
            raise ValueError("a policy-only DQN has no exploration rate: only deterministic actions")
        if self.algorithm != "maskable_ppo":
            return self.policy.predict(observation, state, episode_start, deterministic)
        if action_masks is None:
            if self.observation_layout is None:
                raise ValueError("this policy-only MaskablePPO has no observation layout: pass action_masks")
            from planetnav_env.core.layout import ObservationLayout
            from planetnav_train.masking import observable_mask

            layout = ObservationLayout(**self.observation_layout)
            action_masks = observable_mask(observation, layout, int(self.action_space.n))
        return self.policy.predict(
            observation, state, episode_start, deterministic, action_masks=action_masks
        )


def load_policy_only(path: str | Path) -> PolicyOnlyModel:
    """The :class:`PolicyOnlyModel` of the policy-only export at ``path``."""
    p = Path(path)
    meta, arrays = read_archive(p)
    return PolicyOnlyModel(build_policy(meta, arrays, str(p)), meta, p)


__all__ = [
    "ACTING_RULES",
    "FORMAT",
    "FORMAT_VERSION",
    "META_NAME",
    "PolicyOnlyModel",
    "acting_rule",
    "build_policy",
    "class_path",
    "decode_space",
    "decode_value",
    "encode_space",
    "encode_value",
    "is_policy_only",
    "load_policy_only",
    "read_archive",
    "resolve_class",
    "split_acting",
    "write_archive",
]
