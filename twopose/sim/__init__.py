"""The simulator, on the core.

The scene (``scene``), the renderer (``render``) and the one synthetic camera (``camera``)
that renders a scene from a typed pose as the rig really places it (its ``[systematic]``
constants applied).

The recorder's ``--source synthetic`` and ``twopose-record simulate`` both take frames
from :class:`twopose.sim.camera.SyntheticCamera`, so the recorder rehearses exactly what
the simulator writes. Like the rest of the core, it imports neither ``recorder`` nor
``analysis``.
"""
