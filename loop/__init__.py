"""Closing the loop between measured kinematics and a model.

:mod:`.simulate` (θ(t) of each base model with effects), :mod:`.candidates` (the
effect library), :mod:`.camera_view` (how camera effects bend the measured angle),
:mod:`.evidence` (noise, independent frames, BIC, whiteness, diagnosis),
:mod:`.search` (:func:`~.search.close_loop`: fit, find the missing effect, refit),
:mod:`.result` (what the loop found, and the fit report assembled from it),
:mod:`.leftover` (the shape of a residual no candidate explains),
:mod:`.compare` (the spool model fitted and compared column by column) and
:mod:`.frame_motion` (a shaking frame, from the tracks of A and C).
"""
