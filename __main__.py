"""``cranktrack`` and ``python -m cranktrack``: the command line, started so that a
Ctrl-C at any moment, even while the libraries load, ends in one sentence."""

from __future__ import annotations

import sys


def console() -> int:
    """Entry point of the ``cranktrack`` console script (:func:`cranktrack.cli.main`)."""
    try:
        from .cli import main
    except KeyboardInterrupt:
        print("cranktrack: interrupted while starting; nothing was written", file=sys.stderr)
        return 130
    return main()


if __name__ == "__main__":
    sys.exit(console())
