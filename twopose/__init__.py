"""twopose core: what the recorder and the analysis share.

The exception hierarchy (:mod:`twopose.errors`), the camera model (:mod:`twopose.camera.model`),
the detectors (:mod:`twopose.detect.detection`), the solvers and their uncertainty
(:mod:`twopose.solve.nview`, :mod:`twopose.uncertainty.propagate`), the detection overlay
(:mod:`twopose.display.scene`), the TOML reader (:mod:`twopose.values.toml`) and the session file
format (:mod:`twopose.format`). It imports neither ``recorder`` nor ``analysis``; importing
this package loads nothing heavy.

What a notebook or another program uses is exported here, each name loaded on first use::

    import twopose
    spec = twopose.spec_of("ground")  # the method registry: twopose.METHOD_SPECS
    for path in twopose.find_sessions(["sessions/"]):
        with twopose.SessionReader(path) as session:
            ...
    from twopose.detect.detection import detect  # the module twopose.detect.detection holds it
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
    from twopose.camera.model import Camera, Intrinsics, camera_rays, project_points
    from twopose.detect.detection import Detection, DotParams, GloveParams
    from twopose.errors import (
        InputValueError,
        SceneError,
        SessionExistsError,
        SessionFormatError,
        SessionVersionError,
        SourceError,
        TwoposeError,
    )
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
    from twopose.guidance.advice import Advice, Guidance, advise, suggest
    from twopose.installed_version import __version__
    from twopose.methods.planes import (
        CONSTRAINT_PLANES,
        GROUND_PLANE,
        ConstraintPlane,
        register_plane,
    )
    from twopose.methods.specs import (
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
    from twopose.registry import load_extensions
    from twopose.solve.estimate import EstimateOptions, solve_batch
    from twopose.solve.nview import (
        NViewLines,
        NViewPoints,
        triangulate_ground,
        triangulate_lines,
        triangulate_points,
    )
    from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session
    from twopose.solve.two_view import triangulate_two_views
    from twopose.uncertainty.propagate import Propagated, propagate
    from twopose.values.choices import TARGET_SPECS, TARGETS, Target, TargetSpec, register_target
    from twopose.values.units import DEFAULT_UNITS, UNIT_SPECS, UNITS, Units, UnitSpec, unit_spec

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
    "Camera": "twopose.camera.model",
    "Intrinsics": "twopose.camera.model",
    "camera_rays": "twopose.camera.model",
    "project_points": "twopose.camera.model",
    "MEASURING_METHODS": "twopose.methods.specs",
    "METHOD_SPECS": "twopose.methods.specs",
    "METHODS": "twopose.methods.specs",
    "Method": "twopose.methods.specs",
    "MethodSpec": "twopose.methods.specs",
    "label_of": "twopose.methods.specs",
    "Solver": "twopose.methods.specs",
    "register_method": "twopose.methods.specs",
    "TARGET_SPECS": "twopose.values.choices",
    "TARGETS": "twopose.values.choices",
    "Target": "twopose.values.choices",
    "TargetSpec": "twopose.values.choices",
    "register_target": "twopose.values.choices",
    "CONSTRAINT_PLANES": "twopose.methods.planes",
    "GROUND_PLANE": "twopose.methods.planes",
    "ConstraintPlane": "twopose.methods.planes",
    "register_plane": "twopose.methods.planes",
    "load_extensions": "twopose.registry",
    "spec_of": "twopose.methods.specs",
    "DEFAULT_UNITS": "twopose.values.units",
    "UNIT_SPECS": "twopose.values.units",
    "UNITS": "twopose.values.units",
    "UnitSpec": "twopose.values.units",
    "Units": "twopose.values.units",
    "unit_spec": "twopose.values.units",
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
    "Detection": "twopose.detect.detection",
    "DotParams": "twopose.detect.detection",
    "GloveParams": "twopose.detect.detection",
    "NViewLines": "twopose.solve.nview",
    "NViewPoints": "twopose.solve.nview",
    "triangulate_ground": "twopose.solve.nview",
    "triangulate_lines": "twopose.solve.nview",
    "triangulate_points": "twopose.solve.nview",
    "triangulate_two_views": "twopose.solve.two_view",
    "EstimateOptions": "twopose.solve.estimate",
    "solve_batch": "twopose.solve.estimate",
    "SessionEstimate": "twopose.solve.session",
    "SessionTrials": "twopose.solve.session",
    "estimate_session": "twopose.solve.session",
    "Propagated": "twopose.uncertainty.propagate",
    "propagate": "twopose.uncertainty.propagate",
    "Advice": "twopose.guidance.advice",
    "Guidance": "twopose.guidance.advice",
    "advise": "twopose.guidance.advice",
    "suggest": "twopose.guidance.advice",
    # Read from the package's metadata when first asked for (twopose/installed_version.py).
    "__version__": "twopose.installed_version",
}


__getattr__, __dir__ = lazy_exports("twopose", _HOMES, __all__)
