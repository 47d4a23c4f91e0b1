"""The rig's hidden constants, the analyst's side, one module per role.

- :mod:`analysis.rig.data`: sessions' trials prepared for a fit (combined, whitened);
- :mod:`analysis.rig.fit`: the fit from target sessions (likelihood, selection, leave one
  out), and the rig file it writes;
- :mod:`analysis.rig.board`: the fit from board sessions (the core's
  :mod:`twopose.rig.board` over each session's corners);
- :mod:`analysis.rig.calibrate`: ``twopose-analyze rig`` and ``run --rig`` /
  ``--rig-calibration loo`` over a batch;
- :mod:`analysis.rig.scope`: which rig file each session of a run uses.
"""
