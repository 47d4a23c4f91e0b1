"""The rig's hidden constants, the core's side, one module per role.

- :mod:`twopose.rig.constants`: the constants, their plausibility and how they correct a
  typed pose, the intrinsics and the ground plane (the rig file's reader);
- :mod:`twopose.rig.board`: the constants fitted to a checkerboard's corners.
"""
