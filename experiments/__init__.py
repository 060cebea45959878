"""Experiments on the conformal-camera head: perisaccadic psychophysics, Rerun recordings and
saccade agents, with the command line ``python -m experiments {run,visualize,train,evaluate}``.

Subpackages and modules are imported on use (``experiments.psychophysics``,
``experiments.recording``, ``experiments.agents.cli``), so importing ``experiments`` is cheap.
"""
