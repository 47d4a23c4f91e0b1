"""Two cameras at once (issue 58), the core's side: a pair of cameras fixed to each other.

- :mod:`twopose.pair.calibration`: the pair's relative pose from stills of a board both
  cameras see, with its covariance, the fit's RMS and the floor plane
  (:class:`~twopose.pair.calibration.PairCalibration`);
- :mod:`twopose.pair.board_fit`: the board's reprojection in both cameras, the one model
  the pair's fit and the floor's share;
- :mod:`twopose.pair.holdout`: the calibration checked by leave-one-out (held-out boards'
  corner spacings against their predicted sigmas);
- :mod:`twopose.pair.floor`: the floor plane from a board lying on it;
- :mod:`twopose.pair.pair_file`: ``PAIR.toml``'s one reader and writer (docs/pair-file.md);
- :mod:`twopose.pair.pairing`: two cameras' frames paired by capture time;
- :mod:`twopose.pair.clock`: the cameras' clock offset measured, with its 1-sigma;
- :mod:`twopose.pair.dot_tracks`: both cameras' target tracks and the rays' gap at a
  candidate offset, what the offset's search measures;
- :mod:`twopose.pair.flash`: the offset from a flash both cameras see;
- :mod:`twopose.pair.trial_offset`: a stream trial's offset from all it saw (a flash and the
  rays' gap pooled, or refused), the one path of the recorder and the analysis;
- :mod:`twopose.pair.clock_fit`: a camera's frame times fitted by a regular clock, the offset's
  type;
- :mod:`twopose.pair.stream`: the estimate per frame pair of a moving target.

No I/O but the pair file's reader and writer.
"""
