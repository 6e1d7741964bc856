"""The largest value of a map over a grid (rocking angle, torque, work maps)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def grid_max(z: NDArray, columns: NDArray, rows: NDArray) -> tuple[float, float, float]:
    """(largest value of the map ``z``, its column coordinate, its row coordinate); NaN
    cells are skipped."""
    r, c = np.unravel_index(np.nanargmax(z), z.shape)
    return float(z[r, c]), float(columns[c]), float(rows[r])
