"""Scenarios: the motion a render shows, computed from the models in ``kinematics``.

A scenario maps frame times to a :class:`Motion`: plane positions of the
markers and the exact kinematics columns. Later issues add SMA, antagonistic
and free-response scenarios and switchable effects; they only need to return
a :class:`Motion`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from cranktrack.kinematics.crank_slider import crank_state
from cranktrack.kinematics.spool import SpoolDrive


@dataclass(frozen=True)
class Motion:
    """Exact motion at the frame times.

    ``points_mm`` maps marker name to plane positions (n, 2) in mm; the other
    fields are the kinematics of the crank in SI-with-mm units: θ and its
    rates in rad, rad/s, rad/s²; ``vB_mm_s`` (n, 2); ``L3_mm`` and
    ``L3_rate_mm_s``.
    """

    t_s: NDArray[np.float64]
    points_mm: dict[str, NDArray[np.float64]]
    theta: NDArray[np.float64]
    omega: NDArray[np.float64]
    alpha: NDArray[np.float64]
    vB_mm_s: NDArray[np.float64]
    L3_mm: NDArray[np.float64]
    L3_rate_mm_s: NDArray[np.float64]


@dataclass(frozen=True)
class SpoolScenario:
    """The rigid test bed of thesis Table 2.2 driven by the spool at C."""

    drive: SpoolDrive = field(default_factory=SpoolDrive)
    name: str = "spool"

    def motion(self, t_s: ArrayLike) -> Motion:
        """Exact motion at times ``t_s`` (s)."""
        t = np.asarray(t_s, dtype=float)
        slider = self.drive.slider(t)
        state = crank_state(self.drive.bed, slider)
        pos = self.drive.bed.positions(state.theta)
        return Motion(
            t_s=t,
            points_mm={"A": pos["A"], "B": state.B, "C": pos["C"]},
            theta=state.theta,
            omega=state.omega,
            alpha=state.alpha,
            vB_mm_s=state.vB,
            L3_mm=slider.L3,
            L3_rate_mm_s=slider.L3_rate,
        )

    def extent_mm(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Plane box (lo, hi) that holds the whole motion, mm."""
        d = self.drive
        thetas = d.bed.theta(np.linspace(d.L3_0 - d.stroke_mm, d.L3_0, 64))
        b = d.bed.positions(thetas)["B"]
        pts = np.vstack([b, [[0.0, 0.0], [d.L1, 0.0]]])
        return pts.min(axis=0), pts.max(axis=0)

    def to_dict(self) -> dict:
        """Parameters for ``scene.json``."""
        return {"name": self.name, **asdict(self.drive), "stop_s": self.drive.stop_s,
                "theta0_deg": float(np.degrees(self.drive.bed.theta(self.drive.L3_0)))}
