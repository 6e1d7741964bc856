"""The spool drive of the rigid test bed (thesis §2.5.2, Table 2.2).

A servo winds nylon wire onto a spool at C at constant surface speed, so the
slider length L3 shortens linearly from ``L3_0`` once the drive starts, until
the commanded stroke is wound in; then it holds. A torsion spring at A keeps
the wire taut, which this kinematic model takes as given (the dynamics at the
stop are an effect the model lacks, thesis Fig. 2.36).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from cranktrack.errors import CranktrackError
from cranktrack.kinematics.crank_slider import CrankSlider, SliderState

#: Thesis Table 2.2, mm and mm/s.
TABLE_2_2 = {"L1": 160.8, "L2": 72.4, "L3_0": 105.4, "speed_mm_s": 14.0}


@dataclass(frozen=True)
class SpoolDrive:
    """Constant-speed wire winding.

    Parameters
    ----------
    L1, L2, L3_0 : float
        Frame, crank and initial wire length, mm (defaults: thesis Table 2.2).
    speed_mm_s : float
        Winding speed, mm/s (> 0 shortens the wire).
    start_s : float
        Time the drive starts, s.
    stroke_mm : float
        Wire wound in before the drive stops, mm. Must stay below
        ``L3_0 − |L1 − L2|`` (17.0 mm for Table 2.2), where θ reaches 0.
    """

    L1: float = TABLE_2_2["L1"]
    L2: float = TABLE_2_2["L2"]
    L3_0: float = TABLE_2_2["L3_0"]
    speed_mm_s: float = TABLE_2_2["speed_mm_s"]
    start_s: float = 0.5
    stroke_mm: float = 15.0

    def __post_init__(self) -> None:
        limit = self.bed.max_stroke(self.L3_0)
        if not 0 <= self.stroke_mm < limit:
            raise CranktrackError(
                f"a stroke of {self.stroke_mm} mm is not possible: it must be at least 0 and "
                f"below {limit:.2f} mm, where the crank angle reaches 0"
            )
        if self.speed_mm_s <= 0:
            raise CranktrackError(f"the spool speed must be positive, not {self.speed_mm_s} mm/s")

    @property
    def bed(self) -> CrankSlider:
        """The linkage (branch +1: B on the positive-y side)."""
        return CrankSlider(self.L1, self.L2)

    @property
    def stop_s(self) -> float:
        """Time the drive stops, s."""
        return self.start_s + self.stroke_mm / self.speed_mm_s

    def slider(self, t_s: ArrayLike) -> SliderState:
        """L3, L3' and L3'' at times ``t_s`` (s).

        The rate steps at the start and stop instants, where it has no value:
        exactly there L3' and L3'' are NaN (and so are ω, α and v_B derived
        from them), rather than one side's value by convention.
        """
        t = np.asarray(t_s, dtype=float)
        moving = (t > self.start_s) & (t < self.stop_s)
        wound = np.clip(t - self.start_s, 0.0, self.stroke_mm / self.speed_mm_s)
        L3 = self.L3_0 - self.speed_mm_s * wound
        kink = (t == self.start_s) | (t == self.stop_s)
        rate = np.where(kink, np.nan, np.where(moving, -self.speed_mm_s, 0.0))
        accel = np.where(kink, np.nan, 0.0)
        return SliderState(L3=L3, L3_rate=rate, L3_accel=accel)
