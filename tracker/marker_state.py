"""What the tracker carries for one marker from frame to frame."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .centre import Centre
from .markers import AREA_GATE, MarkerSpec

#: A fit whose residual exceeds this many times the marker's usual residual is
#: not a whole disc (partly covered, or something of its colour touching it).
RESIDUAL_LIMIT = 1.6

#: A marker whose visible area Σα differs from its usual by more than this
#: fraction is not whole (partly covered), or not alone.
AREA_TOLERANCE = 0.2

#: A marker's size is learned over the first this many frames it is found in, not
#: from the first alone: on a real clip the first frame was a still in which a
#: sticker showed as a 2 px speck, and every later (whole) view of it was then
#: rejected as too big. Until then its size gates blobs loosely and its look not at
#: all.
LEARN_FINDS = 5


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
    radii_seen: list[float] = field(default_factory=list)  # fitted radii while learning, px

    @property
    def learning(self) -> bool:
        """Still learning the marker's size (found in fewer than :data:`LEARN_FINDS`
        frames)?"""
        return len(self.radii_seen) < LEARN_FINDS

    @property
    def area(self) -> float | None:
        """The marker's expected blob area, px² (from its radius)."""
        return None if self.radius is None else float(np.pi * self.radius**2)

    @property
    def area_gates(self) -> tuple[tuple[float, float], ...]:
        """The blob areas a whole-frame search takes for the marker, as multiples of
        :attr:`area`, each gate tried only when nothing passed the one before:
        :data:`.markers.AREA_GATE` (0.3–3), and while its size is being learned
        0.1–10 after that (a 2.5 px speck that is a 7 px disc later passes; a 0.5 px
        glint beside a 4.5 px ball does not, and a hand 4× the ball's area loses to
        the ball far off)."""
        return (AREA_GATE, (0.1, 10.0)) if self.learning else (AREA_GATE,)

    def whole(self, centre: Centre) -> bool:
        """Does the fit look like the whole marker: its usual visible area and residual?
        (A rim fit has weighed out what covers the marker already; while learning,
        there is no usual yet.)"""
        if centre.rim or self.learning:
            return True
        if self.area_alpha is not None and np.isfinite(centre.area):
            if not 1 - AREA_TOLERANCE <= centre.area / self.area_alpha <= 1 + AREA_TOLERANCE:
                return False
        if self.residual is None or not np.isfinite(centre.rms_residual):
            return True
        return centre.rms_residual <= RESIDUAL_LIMIT * max(self.residual, 0.01)

    def remember(self, centre: Centre, seen: NDArray | None) -> None:
        """Keep the fitted shape and follow slow drift of the marker's colour; while
        learning, its radius is the median of those fitted so far, and its usual
        residual and area are the latest fit's."""
        if self.learning and np.isfinite(centre.radius):
            self.radii_seen.append(centre.radius)
            self.radius = float(np.median(self.radii_seen))
            self.residual = self.area_alpha = None
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
