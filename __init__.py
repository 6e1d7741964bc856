"""cranktrack: machine-vision kinematics of a crank-slider, checked against its models.

Packages: :mod:`cranktrack.tracker` (frames → marker tracks in px),
:mod:`cranktrack.calibration` (px → mm in the mechanism plane),
:mod:`cranktrack.kinematics` (measured kinematics and the thesis's models),
:mod:`cranktrack.synthetic` (renders with known truth).
"""
