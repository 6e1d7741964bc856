"""What the tracker carries for one marker from frame to frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .centre import Centre
from .markers import MarkerSpec

#: A fit whose residual exceeds this many times the marker's usual residual is
#: not a whole disc (partly covered, or something of its colour touching it).
RESIDUAL_LIMIT = 1.6

#: A marker whose visible area Σα differs from its usual by more than this
#: fraction is not whole (partly covered), or not alone.
AREA_TOLERANCE = 0.2

@dataclass
class MarkerState:
    """What the tracker remembers of one marker from frame to frame: what it looks
    like (its learned colour, radius, fitted shape, usual residual and area) and
    where it was (its last fixes, and how many frames it has been missed)."""

    spec: MarkerSpec
    learned: bool = False
    radius: float | None = None  # from the first fit, px
    history: list[tuple[float, float, float]] = field(default_factory=list)  # (t, x, y)
    missed: int = 0  # frames since the last fix (or since the start, never found)
    shape: tuple[float, ...] | None = None  # last fitted disc parameters
    #: Centred by its rim (a shaded ball: the disc fit is pulled toward the light)?
    #: None until decided at the first acquisition.
    rim: bool | None = None
    marker: NDArray | None = None  # learned marker chroma
    residual: float | None = None  # usual RMS residual of the disc fit
    area_alpha: float | None = None  # usual visible area Σα, px²
    notes: list[str] = field(default_factory=list)  # things the user should hear about

    @property
    def area(self) -> float | None:
        """The marker's expected blob area, px² (from its radius)."""
        return None if self.radius is None else float(np.pi * self.radius**2)

    def whole(self, centre: Centre) -> bool:
        """Does the fit look like the whole marker: its usual visible area and residual?
        (A rim fit has weighed out what covers the marker already.)"""
        if centre.rim:
            return True
        if self.area_alpha is not None and np.isfinite(centre.area):
            if not 1 - AREA_TOLERANCE <= centre.area / self.area_alpha <= 1 + AREA_TOLERANCE:
                return False
        if self.residual is None or not np.isfinite(centre.rms_residual):
            return True
        return centre.rms_residual <= RESIDUAL_LIMIT * max(self.residual, 0.01)

    def remember(self, centre: Centre, seen: NDArray | None) -> None:
        """Keep the fitted shape and follow slow drift of the marker's colour."""
        if np.isfinite(centre.rms_residual):
            self.residual = (centre.rms_residual if self.residual is None
                             else 0.9 * self.residual + 0.1 * centre.rms_residual)
        if np.isfinite(centre.area) and not centre.rim:
            self.area_alpha = (centre.area if self.area_alpha is None
                               else 0.9 * self.area_alpha + 0.1 * centre.area)
        self.shape = centre.params
        if seen is not None:
            self.marker = seen if self.marker is None else 0.9 * self.marker + 0.1 * seen

    def predict(self, t: float) -> tuple[float, float] | None:
        """Constant-velocity prediction from the last two fixes (px); the last fix
        itself once the marker has been lost for more than a frame or two (a
        velocity carried on blindly takes the search away from where it was)."""
        if not self.history:
            return None
        t1, x1, y1 = self.history[-1]
        if len(self.history) < 2 or self.missed > 2:
            return x1, y1
        t0, x0, y0 = self.history[-2]
        if t1 <= t0:
            return x1, y1
        k = (t - t1) / (t1 - t0)
        return x1 + k * (x1 - x0), y1 + k * (y1 - y0)

    def speed_px(self) -> float:
        """Displacement between the last two fixes, px."""
        if len(self.history) < 2:
            return 0.0
        (_, x0, y0), (_, x1, y1) = self.history[-2:]
        return float(np.hypot(x1 - x0, y1 - y0))
