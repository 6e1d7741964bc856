"""cranktrack: machine-vision kinematics of a crank-slider, checked against its models.

Packages: :mod:`cranktrack.tracker` (frames → marker tracks in px),
:mod:`cranktrack.calibration` (px → mm in the mechanism plane),
:mod:`cranktrack.kinematics` (measured θ, ω, α, v_B, L3 with σ),
:mod:`cranktrack.models` (the thesis's physics), :mod:`cranktrack.loop` (closing the
loop: fit, residual, missing effect), :mod:`cranktrack.synthetic` (renders with known
truth) and :mod:`cranktrack.report` (figures, Markdown, the Rerun recording).
"""

#: The Python API (:mod:`cranktrack.api`), loaded on first use so that ``import
#: cranktrack`` and the command line start without pandas, numba and PyAV.
_API = ("track", "measure", "open_run", "fit", "flight", "swing", "rotation", "Fit", "RunResult")


def __getattr__(name: str):
    if name in _API:
        from . import api

        return getattr(api, name)
    raise AttributeError(f"module 'cranktrack' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_API])
