"""``NAME=VALUE`` command-line options with numeric values (``--effect``, ``--known``)."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from cranktrack.errors import CranktrackError


def parse_numbers(items: Iterable[str] | None, names: Iterable[str], flag: str, what: str,
                  finite: bool = False) -> dict[str, float]:
    """``["a=1", "b=2.5"]`` → ``{"a": 1.0, "b": 2.5}``, each name one of ``names``.

    ``flag`` and ``what`` word the error (``--effect``, ``a known effect``);
    ``finite`` also refuses NaN and infinities.
    """
    allowed = tuple(names)
    out: dict[str, float] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or name not in allowed:
            raise CranktrackError(f"{flag} {item!r} is not NAME=VALUE with {what} "
                                  f"({', '.join(allowed)})")
        try:
            out[name] = float(value)
        except ValueError:
            raise CranktrackError(f"{flag} {item!r}: {value!r} is not a number") from None
        if finite and not np.isfinite(out[name]):
            raise CranktrackError(f"{flag} {item!r} is not a finite number")
    return out
