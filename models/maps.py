"""Parametric maps over frame length and starting angle (thesis §2.2.2, §2.6).

Everything is normalised to the crank, ``L2 = 1``: the frame length is the
ratio L1/L2. For an actuator that shortens the wire by a fixed fraction of
its starting length (a rigid 5 % contraction, §2.2.2; the muscle's 25 % of
its 55 % contractile part, §2.6), the rocking angle is θ0 − θ_f with θ_f
from the cosine law at the contracted length. Where the contracted wire
cannot close the loop — one of the two incompatibilities of Fig. 2.5 — the
map holds NaN and a reason code.

For an actuator with a force curve (§2.3.1, §2.4) the wire pulls with
F(u) as it contracts by u from blocked (u = 0, F_b) to free (u = u_i): the
torque about A is F times the moment arm, the distance from A to the line
BC (Fig. 2.7), L1·L2·sin θ / L3; the work is ∫F du over the free stroke
(eq. 2.12), which equals ∫torque dθ. Lengths are normalised to a crank of
L2 = 1 m, the scale at which the thesis quotes N·m and J.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .grid import grid_max
from .sma_material import actuator_curve

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
        return grid_max(self.rocking_deg, self.ratio, self.theta0_deg)

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


#: The force actuators, by name: the linearised and the nonlinear SMA wire
#: (§2.4) and the muscle (§2.6), which the thesis says has an actuator curve
#: "similar to that of SMA wire" (Fig. 2.39): the SMA curve's shape, the
#: muscle's stroke, the same blocked force (Table 2.6 gives all three the same
#: peak torque).
FORCE_ACTUATORS = ("linear", "sma", "muscle")


@dataclass(frozen=True)
class ActuatorMap:
    """Rocking angle (deg), peak torque (N·m) and work (J) of a force actuator on a grid.

    Rows are ``theta0_deg``, columns ``ratio`` (L1/L2); NaN where the
    mechanism cannot close (``reason``, as in :class:`RockingMap`).
    """

    ratio: NDArray[np.float64]
    theta0_deg: NDArray[np.float64]
    rocking_deg: NDArray[np.float64]
    torque_Nm: NDArray[np.float64]
    work_J: NDArray[np.float64]
    reason: NDArray[np.int8]
    free_fraction: float

    def optimum(self, field: str) -> tuple[float, float, float]:
        """(largest value of ``field``, its L1/L2, its θ0 deg)."""
        return grid_max(getattr(self, field), self.ratio, self.theta0_deg)


def actuator_map(ratio: NDArray, theta0_deg: NDArray, free_fraction: float,
                 force: Callable[[NDArray], NDArray], L2_m: float = 1.0,
                 n_stroke: int = 65) -> ActuatorMap:
    """Peak torque and work of an actuator over the grid (thesis §2.3.1, §2.4, §2.6).

    ``free_fraction`` is the free stroke as a fraction of the starting wire
    length L3₀; ``force(s)`` the pull in N at fraction ``s`` of that stroke
    (1 − s for a linear actuator of 1 N blocked force). ``n_stroke`` samples
    the stroke; the torque is the largest over them and the work their
    trapezoid. A 200×200 grid takes well under a second.
    """
    rock = rocking_angle_map(ratio, theta0_deg, free_fraction)
    r = np.asarray(ratio, float)[None, :, None]
    th0 = np.radians(np.asarray(theta0_deg, float))[:, None, None]
    s = np.linspace(0.0, 1.0, n_stroke)
    F = np.asarray(force(s), float)
    L3_0 = np.sqrt(r**2 + 1.0 - 2.0 * r * np.cos(th0))
    L3 = L3_0 * (1.0 - free_fraction * s)
    cos_t = np.clip((r**2 + 1.0 - L3**2) / (2.0 * r), -1.0, 1.0)
    arm = r * np.sqrt(1.0 - cos_t**2) / L3  # distance from A to the line BC, in L2
    torque = (F * arm).max(axis=-1) * L2_m
    work = np.trapezoid(F, s) * free_fraction * L3_0[..., 0] * L2_m
    bad = rock.reason != OK
    return ActuatorMap(rock.ratio, rock.theta0_deg, rock.rocking_deg,
                       np.where(bad, np.nan, torque), np.where(bad, np.nan, work), rock.reason,
                       free_fraction)


def force_actuator(name: str) -> tuple[float, Callable[[NDArray], NDArray]]:
    """(free stroke as a fraction of L3₀, force in N against fraction of stroke) by name."""
    curve = actuator_curve()
    if name == "linear":
        curve = curve.linearised()
    elif name not in ("sma", "muscle"):
        raise ValueError(f"unknown force actuator {name!r}; one of {FORCE_ACTUATORS}")
    free = CONTRACTION["muscle"] if name == "muscle" else curve.free_pct / 100.0
    return free, curve.force_at
