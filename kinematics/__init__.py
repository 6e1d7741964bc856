"""Measured kinematics from tracks: θ, ω, α, v_B and L3 with σ (:mod:`.measured`), the
differentiation on real timestamps behind them (:mod:`.differentiate`) and the table's
columns (:mod:`.table`). The models they are checked against are in :mod:`cranktrack.models`.
"""
