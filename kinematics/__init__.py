"""Measured kinematics from tracks, and the analytic models of the thesis."""
