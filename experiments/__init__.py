"""Experiments on the conformal-camera head, by product, and their command line
``python -m experiments COMMAND`` (``python -m experiments --help`` lists every command):

- ``psychophysics``: perisaccadic flash localization (``run``: ``psychophysics.study``), the
  theories and their registry, the scoreboard of published phenomena (``phenomena``);
- ``modelfit``: fitting the theories to a lab's data (``fit``, ``compare``, ``simulate``, ``recovery``);
- ``oculomotor``: eye-tracker recordings, saccade kinematics and the generator fit (``saccades``);
- ``recording``: Rerun recordings and their blueprints (``visualize``, ``view``);
- ``agents``: saccade agents and their recipes (``train``, ``evaluate``, ``baselines``);
- ``cli``: the command line, one module per command (``cli/run.py``, ... : its parser and the entry
  that calls the product's functions), the options several commands share (``cli/options.py``, each
  declared once with one range) and ``run``'s options generated from ``TrialConfig``
  (``cli/trialconfig.py``); ``folders``: locked, atomic, resumable results folders.

Subpackages are imported on use, so importing ``experiments`` is cheap.
"""
