"""The thesis's physics: the models measured kinematics are checked against.

Crank-slider loop closure (:mod:`.crank_slider`), the spool drive (:mod:`.spool`),
the equation of motion (:mod:`.dynamics`), SMA material and heat transfer
(:mod:`.sma_material`, :mod:`.heat`), the SMA and antagonistic beds (:mod:`.sma_bed`,
:mod:`.antagonistic`), parametric maps (:mod:`.maps`) and thermal identification
(:mod:`.thermal_id`). Nothing here reads a video or a run folder.
"""
