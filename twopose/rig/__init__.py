"""The rig's hidden constants, the core's side, one module per role.

- :mod:`twopose.rig.constants`: the constants, their covariance, their plausibility and how
  they correct a typed pose, the intrinsics and the ground plane;
- :mod:`twopose.rig.covariance`: the constants' names and their covariance;
- :mod:`twopose.rig.file`: the rig file's one reader, and the tables ``rig`` writes;
- :mod:`twopose.rig.cameras`: the cameras a rig was fitted for (refused for another);
- :mod:`twopose.rig.carried`: the constants' covariance carried into every region;
- :mod:`twopose.rig.board`: the constants fitted to a checkerboard's corners;
- :mod:`twopose.rig.placing`: the operator's placing sigma a board fit measures (or bounds).
"""
