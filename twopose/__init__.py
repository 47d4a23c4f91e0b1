"""twopose core: what the recorder and the analysis share.

The exception hierarchy (:mod:`twopose.errors`), the camera model (:mod:`twopose.camera`),
the detectors (:mod:`twopose.detect`), the solvers and their uncertainty
(:mod:`twopose.solve`, :mod:`twopose.uncertainty`), the detection overlay
(:mod:`twopose.overlay`), the TOML reader (:mod:`twopose.config`) and the session file
format (:mod:`twopose.format`). It imports neither ``recorder`` nor ``analysis``; importing
this package loads nothing heavy.

What a notebook or another program uses is exported here, each name loaded on first use::

    import twopose
    spec = twopose.spec_of("ground")  # the method registry: twopose.METHOD_SPECS
    for path in twopose.find_sessions(["sessions/"]):
        with twopose.SessionReader(path) as session:
            ...
    from twopose.detect import detect  # the module twopose.detect holds it
    detection = detect(frame_bgr, spec.target)

The camera model (:class:`Camera`, :class:`Intrinsics`), the method, target, plane and
unit registries (:data:`METHOD_SPECS`, :data:`TARGET_SPECS`, :data:`CONSTRAINT_PLANES`,
:data:`UNIT_SPECS`) and their extension points (:func:`register_method`,
:func:`register_target`, :func:`register_plane`; the frame sources' is
``recorder.register_source``), the errors (every one a :class:`TwoposeError`),
reading and writing sessions, detection, the solvers' one-call functions
(:func:`triangulate_points`, :func:`triangulate_lines`, :func:`triangulate_ground`,
:func:`estimate_session`), their uncertainty (:func:`propagate`) and the guidance
(:class:`Guidance`). Everything else is in its module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.camera import Camera, Intrinsics, camera_rays, project_points
    from twopose.choices import TARGET_SPECS, TARGETS, Target, TargetSpec, register_target
    from twopose.detect import Detection, DotParams, GloveParams
    from twopose.errors import (
        InputValueError,
        SceneError,
        SessionExistsError,
        SessionFormatError,
        SessionVersionError,
        SourceError,
        TwoposeError,
    )
    from twopose.estimate import EstimateOptions, solve_batch
    from twopose.format import (
        FORMAT_VERSION,
        GroundPlane,
        GroundTruth,
        PlaneEntry,
        SessionInfo,
        SessionReader,
        SessionWriter,
        TruePose,
        find_sessions,
    )
    from twopose.guidance import Advice, Guidance, advise, suggest
    from twopose.installed_version import __version__
    from twopose.methods import (
        MEASURING_METHODS,
        METHOD_SPECS,
        METHODS,
        Method,
        MethodSpec,
        Solver,
        label_of,
        register_method,
        spec_of,
    )
    from twopose.planes import CONSTRAINT_PLANES, GROUND_PLANE, ConstraintPlane, register_plane
    from twopose.registry import load_extensions
    from twopose.session_estimate import SessionEstimate, SessionTrials, estimate_session
    from twopose.solve import (
        NViewLines,
        NViewPoints,
        triangulate_ground,
        triangulate_lines,
        triangulate_points,
    )
    from twopose.two_view import triangulate_two_views
    from twopose.uncertainty import Propagated, propagate
    from twopose.units import DEFAULT_UNITS, UNIT_SPECS, UNITS, Units, UnitSpec, unit_spec

__all__ = [
    "CONSTRAINT_PLANES",
    "DEFAULT_UNITS",
    "FORMAT_VERSION",
    "GROUND_PLANE",
    "MEASURING_METHODS",
    "METHODS",
    "METHOD_SPECS",
    "TARGETS",
    "TARGET_SPECS",
    "UNITS",
    "UNIT_SPECS",
    "Advice",
    "Camera",
    "ConstraintPlane",
    "Detection",
    "DotParams",
    "EstimateOptions",
    "GloveParams",
    "GroundPlane",
    "GroundTruth",
    "Guidance",
    "InputValueError",
    "Intrinsics",
    "Method",
    "MethodSpec",
    "NViewLines",
    "NViewPoints",
    "PlaneEntry",
    "Propagated",
    "SceneError",
    "SessionEstimate",
    "SessionExistsError",
    "SessionFormatError",
    "SessionInfo",
    "SessionReader",
    "SessionTrials",
    "SessionVersionError",
    "SessionWriter",
    "Solver",
    "SourceError",
    "Target",
    "TargetSpec",
    "TruePose",
    "TwoposeError",
    "UnitSpec",
    "Units",
    "__version__",
    "advise",
    "camera_rays",
    "estimate_session",
    "find_sessions",
    "label_of",
    "load_extensions",
    "project_points",
    "propagate",
    "register_method",
    "register_plane",
    "register_target",
    "solve_batch",
    "spec_of",
    "suggest",
    "triangulate_ground",
    "triangulate_lines",
    "triangulate_points",
    "triangulate_two_views",
    "unit_spec",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "Camera": "twopose.camera",
    "Intrinsics": "twopose.camera",
    "camera_rays": "twopose.camera",
    "project_points": "twopose.camera",
    "MEASURING_METHODS": "twopose.methods",
    "METHOD_SPECS": "twopose.methods",
    "METHODS": "twopose.methods",
    "Method": "twopose.methods",
    "MethodSpec": "twopose.methods",
    "label_of": "twopose.methods",
    "Solver": "twopose.methods",
    "register_method": "twopose.methods",
    "TARGET_SPECS": "twopose.choices",
    "TARGETS": "twopose.choices",
    "Target": "twopose.choices",
    "TargetSpec": "twopose.choices",
    "register_target": "twopose.choices",
    "CONSTRAINT_PLANES": "twopose.planes",
    "GROUND_PLANE": "twopose.planes",
    "ConstraintPlane": "twopose.planes",
    "register_plane": "twopose.planes",
    "load_extensions": "twopose.registry",
    "spec_of": "twopose.methods",
    "DEFAULT_UNITS": "twopose.units",
    "UNIT_SPECS": "twopose.units",
    "UNITS": "twopose.units",
    "UnitSpec": "twopose.units",
    "Units": "twopose.units",
    "unit_spec": "twopose.units",
    "InputValueError": "twopose.errors",
    "SceneError": "twopose.errors",
    "SessionExistsError": "twopose.errors",
    "SessionFormatError": "twopose.errors",
    "SessionVersionError": "twopose.errors",
    "SourceError": "twopose.errors",
    "TwoposeError": "twopose.errors",
    "FORMAT_VERSION": "twopose.format",
    "PlaneEntry": "twopose.format",
    "GroundPlane": "twopose.format",
    "GroundTruth": "twopose.format",
    "SessionInfo": "twopose.format",
    "SessionReader": "twopose.format",
    "SessionWriter": "twopose.format",
    "TruePose": "twopose.format",
    "find_sessions": "twopose.format",
    "Detection": "twopose.detect",
    "DotParams": "twopose.detect",
    "GloveParams": "twopose.detect",
    "NViewLines": "twopose.solve",
    "NViewPoints": "twopose.solve",
    "triangulate_ground": "twopose.solve",
    "triangulate_lines": "twopose.solve",
    "triangulate_points": "twopose.solve",
    "triangulate_two_views": "twopose.two_view",
    "EstimateOptions": "twopose.estimate",
    "solve_batch": "twopose.estimate",
    "SessionEstimate": "twopose.session_estimate",
    "SessionTrials": "twopose.session_estimate",
    "estimate_session": "twopose.session_estimate",
    "Propagated": "twopose.uncertainty",
    "propagate": "twopose.uncertainty",
    "Advice": "twopose.guidance",
    "Guidance": "twopose.guidance",
    "advise": "twopose.guidance",
    "suggest": "twopose.guidance",
    # Read from the package's metadata when first asked for (twopose/installed_version.py).
    "__version__": "twopose.installed_version",
}


__getattr__, __dir__ = lazy_exports("twopose", _HOMES, __all__)
