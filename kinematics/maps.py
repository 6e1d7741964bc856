"""Parametric maps over frame length and starting angle (thesis §2.2.2, §2.6).

Everything is normalised to the crank, ``L2 = 1``: the frame length is the
ratio L1/L2. For an actuator that shortens the wire by a fixed fraction of
its starting length (a rigid 5 % contraction, §2.2.2; the muscle's 25 % of
its 55 % contractile part, §2.6), the rocking angle is θ0 − θ_f with θ_f
from the cosine law at the contracted length. Where the contracted wire
cannot close the loop — one of the two incompatibilities of Fig. 2.5 — the
map holds NaN and a reason code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

#: Fractional contraction of each fixed-contraction actuator.
CONTRACTION = {
    "rigid": 0.05,  # §2.2.2: "the slider length is initially assumed to reduce by 5 %"
    "muscle": 0.25 * 0.55,  # §2.6: 25 % of the contractile part, 55 % of the musculotendon
}

#: Reason codes in :attr:`RockingMap.reason`.
OK, FRAME_TOO_SHORT, CRANK_TOO_SHORT = 0, 1, 2


@dataclass(frozen=True)
class RockingMap:
    """Rocking angle (deg) on a grid: ``ratio`` (L1/L2, columns) × ``theta0_deg`` (rows)."""

    ratio: NDArray[np.float64]
    theta0_deg: NDArray[np.float64]
    rocking_deg: NDArray[np.float64]
    reason: NDArray[np.int8]
    contraction: float

    def optimum(self) -> tuple[float, float, float]:
        """(largest rocking angle deg, its L1/L2, its θ0 deg)."""
        i = np.nanargmax(self.rocking_deg)
        r, c = np.unravel_index(i, self.rocking_deg.shape)
        return float(self.rocking_deg[r, c]), float(self.ratio[c]), float(self.theta0_deg[r])

    def at(self, ratio: float, theta0_deg: float) -> float:
        """The rocking angle at one point (computed exactly, not interpolated)."""
        m = rocking_angle_map(np.array([ratio]), np.array([theta0_deg]), self.contraction)
        return float(m.rocking_deg[0, 0])


def rocking_angle_map(ratio: NDArray, theta0_deg: NDArray, contraction: float) -> RockingMap:
    """Rocking angle for a wire that shortens by ``contraction`` of its start length.

    Vectorised over the whole grid (a 200×200 map takes milliseconds).

    Examples
    --------
    >>> m = rocking_angle_map(np.array([2.0]), np.array([90.0]), 0.05)
    >>> round(float(m.rocking_deg[0, 0]), 3)
    7.0
    """
    r = np.asarray(ratio, float)[None, :]
    th0 = np.radians(np.asarray(theta0_deg, float))[:, None]
    L3_0 = np.sqrt(r**2 + 1.0 - 2.0 * r * np.cos(th0))
    L3_f = (1.0 - contraction) * L3_0
    reason = np.full(np.broadcast(r, th0).shape, OK, np.int8)
    reason[np.broadcast_to(r + L3_f < 1.0, reason.shape)] = FRAME_TOO_SHORT
    reason[np.broadcast_to(1.0 + L3_f < r, reason.shape)] = CRANK_TOO_SHORT
    with np.errstate(invalid="ignore"):
        theta_f = np.arccos(np.clip((r**2 + 1.0 - L3_f**2) / (2.0 * r), -1.0, 1.0))
    rocking = np.degrees(th0 - theta_f)
    rocking = np.where(reason == OK, rocking, np.nan)
    return RockingMap(np.asarray(ratio, float), np.asarray(theta0_deg, float), rocking, reason,
                      contraction)


def default_grid(n: int = 200) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The thesis's ranges: L1/L2 from 0.5 to 60 and θ0 from 45° to 175°."""
    return np.linspace(0.5, 60.0, n), np.linspace(45.0, 175.0, n)
