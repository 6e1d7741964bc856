"""Scenes rendered from the models, with the ground truth written beside each video."""
