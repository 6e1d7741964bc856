"""cranktrack: machine-vision kinematics of a crank-slider, checked against its models.

Packages: :mod:`cranktrack.tracker` (frames → marker tracks in px),
:mod:`cranktrack.calibration` (px → mm in the mechanism plane),
:mod:`cranktrack.kinematics` (measured θ, ω, α, v_B, L3 with σ),
:mod:`cranktrack.models` (the thesis's physics), :mod:`cranktrack.loop` (closing the
loop: fit, residual, missing effect), :mod:`cranktrack.synthetic` (renders with known
truth) and :mod:`cranktrack.report` (figures, Markdown, the Rerun recording).
"""
