"""Where a trained ThrustArc policy and ``optimum`` disagree, along the policy's own trajectory of one seed
(research/operations_log.md §7.4): the student drives, ``optimum`` labels each decision (DAgger's
relabelling).

    python research/operations/diag_clone.py RUN_DIR/model.zip 10000

Prints the number of decisions, how many each images, the disagreement rate, and every decision where
either images: its environment step, the teacher's and the student's action, and the student's action
probabilities (the last action, 3, is "stay at the mission attitude").
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch
from stable_baselines3 import PPO

from planetnav_train.config import load_config
from planetnav_train.pretrain import demonstrations

CONFIG = Path(__file__).resolve().parent / "thrust_arc_tcm_bc.yaml"


def main(model_path: str, seed: int) -> None:
    tc = load_config(CONFIG)
    model = PPO.load(model_path, device="cpu")
    obs, labels = demonstrations(
        tc.env_config(),
        "optimum",
        1,
        list(tc.features),
        student=model,
        first_seed=seed,
    )
    with torch.no_grad():
        probs = model.policy.get_distribution(torch.as_tensor(obs)).distribution.probs.numpy()
    acts = probs.argmax(1)
    stay = probs.shape[1] - 1
    print(
        "decisions",
        len(labels),
        "teacher images",
        int((labels != stay).sum()),
        "student images",
        int((acts != stay).sum()),
        "disagree",
        float((acts != labels).mean()),
    )
    per_decision = tc.env_config().decision_steps
    for k in np.where((labels != stay) | (acts != stay))[0]:
        print(k * per_decision, "teacher", labels[k], "student", acts[k], np.round(probs[k], 2))


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: python research/operations/diag_clone.py MODEL_ZIP SEED")
    main(sys.argv[1], int(sys.argv[2]))
