"""What the closed loop found: each candidate's score and the loop's result.

:class:`LoopResult` is what :func:`.search.close_loop` returns; ``to_dict`` is
the one place the fit's report (``fit/report.json``) is assembled from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .candidates import CAMERA_CANDIDATES
from .evidence import BIC_THRESHOLD, IMPRINT_SIGMAS, WHITE_P, ModelFit, NoiseModel
from .simulate import MODELS


@dataclass(frozen=True)
class CandidateScore:
    """One candidate tried on top of the current model in one round.

    ``imprint_deg`` is the largest change the effect makes to θ at its
    fitted value; ``resolvable`` says whether that rises above the noise
    (:data:`IMPRINT_SIGMAS`) anywhere — an effect smaller than the tracker's own error cannot
    be told from it, however well it happens to bend around that error.
    """

    name: str
    round: int
    delta_bic: float
    rmse_deg: float
    values: dict[str, float]
    sigmas: dict[str, float]
    imprint_deg: float
    ci_excludes_off: bool
    plausible: bool
    resolvable: bool
    accepted: bool = False
    note: str = ""
    #: Why the effect cannot be, whatever its fit: the rigid links contradict a camera
    #: effect, or it fits only with a value it has nowhere near on its own.
    veto: str = ""

    @property
    def passes(self) -> bool:
        return (self.delta_bic > BIC_THRESHOLD and self.ci_excludes_off and self.plausible
                and self.resolvable and not self.veto)

    def why_not(self) -> str:
        why = [self.veto] if self.veto else []
        if self.delta_bic <= BIC_THRESHOLD:
            why.append(f"ΔBIC {self.delta_bic:.1f} ≤ {BIC_THRESHOLD:g}")
        if not self.ci_excludes_off:
            why.append("its 95 % interval includes no effect")
        if not self.plausible:
            why.append("value not physically plausible or stuck on a bound")
        if not self.resolvable:
            why.append(f"its imprint ({self.imprint_deg:.3g}°) is below {IMPRINT_SIGMAS:g}σ "
                       "of the noise")
        return "; ".join(why) or "a better candidate was accepted"

    def to_dict(self) -> dict:
        return {"name": self.name, "round": self.round, "delta_bic": self.delta_bic,
                "rmse_deg": self.rmse_deg, "imprint_deg": self.imprint_deg,
                "parameters": {k: {"value": v, "sigma": self.sigmas.get(k)}
                               for k, v in self.values.items()},
                "ci_excludes_off": self.ci_excludes_off, "plausible": self.plausible,
                "resolvable": self.resolvable, "accepted": self.accepted, "note": self.note,
                "veto": self.veto}


@dataclass(frozen=True)
class LoopResult:
    """What the loop found: the base fit, each accepted step, every candidate's score."""

    model: str
    known: dict[str, float]
    base: ModelFit
    final: ModelFit
    steps: list[ModelFit]
    scores: list[CandidateScore]
    not_separable: list[dict]
    groups: list[dict]
    diagnosis_before: dict
    diagnosis_after: dict
    noise: NoiseModel
    tracker_sigma_deg: float
    links: dict = field(default_factory=dict)
    messages: list[str] = field(default_factory=list)
    #: The frame-motion check (:func:`.frame_motion.frame_shake`), when the run has
    #: plane tracks of A and C: a shake θ cannot show.
    frame_motion: dict | None = None
    #: Effects that improved the fit but left a structured residual well above the
    #: noise: not named, as they may stand in for something outside the library.
    tentative: tuple[str, ...] = ()
    #: The signature of a residual no candidate explains (:func:`.leftover.signature`).
    leftover: dict | None = None

    @property
    def shake_accepted(self) -> bool:
        return bool(self.frame_motion and self.frame_motion["accepted"])

    @property
    def effects(self) -> list[str]:
        """Accepted effects in order: θ's, then a shaking frame if found."""
        return list(self.final.effects) + (["pivot_amp_mm"] if self.shake_accepted else [])

    def to_dict(self) -> dict:
        spec = MODELS[self.model]
        units = {**{k: p.unit for k, p in spec.base.items()},
                 **{p.name: p.unit for c in (*spec.candidates.values(),
                                             *CAMERA_CANDIDATES.values()) for p in c.parameters}}
        sig = self.final.sigmas(self.noise)
        params = {}
        for k, v in self.final.values.items():
            entry = {"value": v, "unit": units.get(k, ""), "fixed": k not in sig}
            if k in sig:
                entry.update(sigma=sig[k], ci95=[v - 1.96 * sig[k], v + 1.96 * sig[k]])
            params[k] = entry
        if self.shake_accepted:
            fm = self.frame_motion
            for k, unit, v, sd in (("pivot_amp_mm", "mm", fm["amp_mm"], fm["amp_sigma_mm"]),
                                   ("pivot_hz", "Hz", fm["hz"], fm["hz_sigma"])):
                params[k] = {"value": v, "unit": unit, "fixed": False, "sigma": sd,
                             "ci95": [v - 1.96 * sd, v + 1.96 * sd]}
        before, after = self.diagnosis_before, self.diagnosis_after
        level = self.tracker_sigma_deg or self.noise.sigma_deg
        unexplained = None
        if self.leftover is not None:
            unexplained = "the residual stays structured and matches no candidate: " + (
                self.leftover["sentence"] or "no simple shape describes it")
            if self.tentative:
                unexplained += (f"; {', '.join(self.tentative)} improved the fit but did not "
                                "account for it, so none is named: each may stand in for "
                                "something not in the library")
            if self.links.get("camera_effect_suspected"):
                unexplained += "; " + self.links["reading"]
        return {
            "model": self.model,
            "known": self.known,
            "effects": self.effects,
            "rmse_before_deg": before["rmse_deg"],
            "rmse_after_deg": after["rmse_deg"],
            "max_before_deg": before["max_deg"],
            "max_after_deg": after["max_deg"],
            "fit_percent_before": before["fit_percent"],
            "fit_percent_after": after["fit_percent"],
            "noise": self.noise.to_dict(),
            "tracker_sigma_deg": self.tracker_sigma_deg,
            "residual_white_before": bool(before["ljung_box_p"] >= WHITE_P),
            "residual_white_after": bool(after["ljung_box_p"] >= WHITE_P),
            "residual_at_noise_level_after": bool(after["rmse_deg"] <= 1.5 * level),
            "parameters": params,
            "steps": [{"effect": s.effects[-1], "rmse_deg": s.rmse_deg} for s in self.steps],
            "candidates": [s.to_dict() for s in self.scores],
            "not_separable": self.not_separable,
            "look_alike_groups": self.groups,
            "links": self.links,
            "camera_effect_suspected": bool(self.links.get("camera_effect_suspected", False)),
            "unexplained": unexplained,
            "tentative_effects": list(self.tentative),
            "leftover": self.leftover,
            "diagnosis_before": before,
            "diagnosis_after": after,
            "messages": self.messages,
            "frame_motion": self.frame_motion,
        }
