"""What the research commands of this folder share: the exit status on a bad input, ``--option KEY=VALUE``.

Each script here is ``python research/commands/<name>.py [options]``; ``main(argv)`` returns the exit status
as the training command line does (2 with the message on stderr for a configuration or input error). The
environment and evaluation options (``--config``, ``--episodes``, ``--seed``, ``--episode-steps``,
``--noise-streams``, ``--json``) are those of ``evaluate`` (``planetnav_train.cli.add_evaluation_arguments``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import Any

from planetnav_env.errors import ConfigError


def option_pair(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of ``--option``: the value as YAML reads it (``0.5``, ``true``, ``[a, b]``)."""
    import yaml

    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"--option takes KEY=VALUE, got {text!r}")
    return key, yaml.safe_load(value)


def run(
    parser: argparse.ArgumentParser, command: Callable[[argparse.Namespace], int], argv: Sequence[str] | None
) -> int:
    """Parse ``argv`` (default ``sys.argv[1:]``) and run ``command``; a configuration or input error prints
    ``error: ...`` on stderr and returns 2."""
    args = parser.parse_args(list(sys.argv[1:] if argv is None else argv))
    try:
        return command(args)
    except (ConfigError, FileNotFoundError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
