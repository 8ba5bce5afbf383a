"""``python -m planetnav_validation.reproduce NAME [options]``: reproduce one source paper.

Each NAME maps to a module of this package with a ``main(argv) -> int``.
"""

from __future__ import annotations

import importlib
import sys

EXPERIMENTS = {
    "angular-size": "planetnav_validation.reproduce.angular_size",
    "optical-pulsar": "planetnav_validation.reproduce.optical_pulsar",
    "gnss-magnetometer": "planetnav_validation.reproduce.gnss_magnetometer",
}


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in {"-h", "--help"}:
        print(__doc__)
        print("experiments:", ", ".join(EXPERIMENTS))
        return 0 if argv else 2
    name, rest = argv[0], argv[1:]
    if name not in EXPERIMENTS:
        print(f"unknown experiment {name!r}; choose one of: {', '.join(EXPERIMENTS)}", file=sys.stderr)
        return 2
    module = importlib.import_module(EXPERIMENTS[name])
    return int(module.main(rest) or 0)


if __name__ == "__main__":
    raise SystemExit(main())
