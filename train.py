#!/usr/bin/env python
"""Train Stable-Baselines3 agents on planetnav and compare them with the rule-based agents.

The command line over :mod:`planetnav_train` (commands, options and outputs: :mod:`planetnav_train.cli`,
docs/howto_training.md). ``python train.py`` runs the default training run (``train --config
configs/cruise_ppo.yaml``). Nothing imports this file: code and tests import :mod:`planetnav_train`.
"""

import sys

from planetnav_train.cli import main

if __name__ == "__main__":
    sys.exit(main())
