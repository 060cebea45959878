"""Turski's conformal camera: geometry, exp-polar retina, DPFT, remapping and cortex.

Pure math on numpy arrays; never imports MuJoCo, so it works on any image.
"""
