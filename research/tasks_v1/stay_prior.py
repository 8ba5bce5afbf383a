"""Probe: PPO whose *initial* policy stays on its target with probability ``--stay`` (the relative action 0),
the other relative actions sharing the rest; everything else as ``train.py``'s arguments say.

SB3 initializes the action head near zero, so a fresh PPO policy on RandomCruise-Target-v1's three relative
actions switches target at two decisions of three (~97 slews per episode against greedy's 17). This sets
the action head's bias to the log-probabilities of the prior instead; the weights keep SB3's initialization.
It tests whether the switching rate that PPO starts from is what holds it (an exploration prior, no
information from a rule agent).

    python research/tasks_v1/stay_prior.py --stay 0.9 train \
        --config research/tasks_v1/random_cruise_v1_ppo_rorder_stay90.yaml --no-eval
"""

from __future__ import annotations

import argparse
import math
import runpy
import sys
from pathlib import Path

import planetnav_train.training as training

ROOT = Path(__file__).resolve().parents[2]


def with_stay_prior(algorithm_class, stay: float):
    """``algorithm_class`` whose models start with the action head's bias at log(stay), log((1 - stay) /
    (n - 1)) for the other ``n - 1`` discrete actions."""

    def build(name: str):
        cls = algorithm_class(name)

        class StayPrior(cls):
            def _setup_model(self) -> None:
                super()._setup_model()
                import torch

                n = int(self.action_space.n)
                bias = torch.full((n,), math.log((1.0 - stay) / (n - 1)))
                bias[0] = math.log(stay)
                with torch.no_grad():
                    self.policy.action_net.bias.copy_(bias)

        StayPrior.__name__ = cls.__name__
        return StayPrior

    return build


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stay", type=float, required=True, help="initial probability of action 0 (0..1)")
    args, rest = parser.parse_known_args()
    if not 0.0 < args.stay < 1.0:
        parser.error(f"--stay {args.stay} is not between 0 and 1")
    training.algorithm_class = with_stay_prior(training.algorithm_class, args.stay)
    sys.argv = [str(ROOT / "train.py"), *rest]
    runpy.run_path(str(ROOT / "train.py"), run_name="__main__")


if __name__ == "__main__":
    main()
