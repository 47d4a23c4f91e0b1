"""The method and unit registries: every member has its spec, names stay the file's, and
an unknown name is refused naming the known ones."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from twopose.errors import InputValueError
from twopose.format.entries import SessionInfo, decode_entry, encode_entry
from twopose.methods.specs import (
    FLOOR_MEASURED_SIZES,
    MEASURING_METHODS,
    METHOD_SPECS,
    METHODS,
    Method,
    spec_of,
)
from twopose.values.bounds import POSE_TRANSLATION
from twopose.values.choices import Target
from twopose.values.units import UNIT_SPECS, UNITS, Units, unit_spec

REPO = Path(__file__).resolve().parents[2]


def test_every_method_and_unit_has_its_spec() -> None:
    assert set(METHOD_SPECS) == set(METHODS)
    assert METHODS == (Method.POINT, Method.LINE, Method.GROUND, Method.BOARD)  # the thesis'
    assert MEASURING_METHODS == (Method.POINT, Method.LINE, Method.GROUND)
    assert set(UNIT_SPECS) == set(Units)
    assert UNITS[0] == Units.IN  # the default
    for method, spec in METHOD_SPECS.items():
        assert spec.method is method
    for units, unit in UNIT_SPECS.items():
        assert unit.units is units


def test_what_each_method_is() -> None:
    point, line, ground = (spec_of(m) for m in ("point", "line", "ground"))
    assert (point.target, line.target, ground.target) == (
        Target.DOT.spec,
        Target.GLOVE.spec,
        Target.GLOVE.spec,
    )
    assert (point.truth_points, line.truth_points, ground.truth_points) == (1, 2, 1)
    assert [s.needs_ground for s in (point, line, ground)] == [False, False, True]
    assert [s.estimates_line for s in (point, line, ground)] == [False, True, False]
    assert [s.uses_image_lines for s in (point, line, ground)] == [False, True, True]
    # Every method's margins include the parallax; method 2 adds the line-ground angle.
    assert all(s.margins[0] == "parallax_deg" for s in (point, line, ground))
    assert "line_plane_angle_deg" in ground.margins
    assert "line_plane_angle_deg" not in line.margins


def test_a_board_session_reconstructs_nothing_and_carries_its_board() -> None:
    board = spec_of("board")
    assert not board.measures
    assert board.target is None
    assert board.truth_kind is None
    assert board.truth_points == 0
    assert not board.needs_ground
    assert (board.margins, board.extra_columns) == ((), ())
    assert all(spec_of(m).measures for m in MEASURING_METHODS)


def test_units_agree_with_each_other() -> None:
    assert unit_spec("mm").inches == pytest.approx(1 / 25.4)
    for spec in UNIT_SPECS.values():
        # The limits are the same lengths in every unit (twopose.values.bounds); the ground
        # tolerance is checked exactly in tests/twopose/test_units.py.
        high = POSE_TRANSLATION.limits(spec.units)[1]
        assert high * spec.inches == pytest.approx(200, rel=1e-6)


def test_the_types_are_their_names() -> None:
    assert str(Method.POINT) == "point"
    assert Method("point") == Method.POINT
    assert f"{Method.GROUND}" == "ground"
    assert json.dumps([Method.LINE, Units.CM]) == '["line", "cm"]'


@pytest.mark.parametrize(
    ("call", "name", "message"),
    [
        (spec_of, "plane", "method must be one of point, line, ground, board, got 'plane'"),
        (spec_of, "", "method must be one of"),
        (spec_of, "POINT", "got 'POINT'"),
        (unit_spec, "furlongs", "units must be one of in, mm, cm, m, got 'furlongs'"),
    ],
)
def test_an_unknown_name_is_refused_naming_the_known_ones(
    call: object, name: str, message: str
) -> None:
    with pytest.raises(InputValueError, match=message):
        call(name)  # type: ignore[operator]


def test_session_info_holds_the_types_and_writes_the_names() -> None:
    info = SessionInfo(method=Method.GROUND, units=Units.MM)
    assert info.method is Method.GROUND
    assert info.units is Units.MM
    encoded = encode_entry(info)
    assert json.loads(encoded)["method"] == "ground"
    assert decode_entry(SessionInfo.SCHEMA_NAME, encoded) == info
    with pytest.raises(InputValueError, match="got 'plane'"):
        SessionInfo(method="plane", units=Units.IN)  # type: ignore[arg-type]


def _floor_figure() -> tuple[list[str], list[str]]:
    """docs/figures/detector_floor.txt's two tables' rows: per detector and geometry, and a
    camera of a pair's per method and size."""
    lines = (REPO / "docs" / "figures" / "detector_floor.txt").read_text().splitlines()
    second = next(k for k, line in enumerate(lines) if line.startswith("a camera of a pair"))
    return lines[2:second], lines[second + 2 : -1]


def test_each_detectors_one_camera_floor_covers_the_thesis_geometry() -> None:
    """The registry's ``detector_floor`` is at least the systematic error the benchmark
    measured in the thesis' one camera (docs/figures/detector_floor.txt), and the figure
    measured each camera of the simulator's pair too."""
    rows, _ = _floor_figure()
    header = (REPO / "docs" / "figures" / "detector_floor.txt").read_text().splitlines()[1]
    names = header.split()  # detector, geometry, error (words with spaces), then one a column
    systematic = names.index("systematic") - names.index("error") - 1
    row_re = re.compile(r"\s*(\w+)\s+(.+?)\s+(across|orientation|centroid [xy]) (px|deg)\s+(.*)")
    measured: dict[tuple[str, str], float] = {}
    geometries = set()
    for line in rows:
        match = row_re.fullmatch(line)
        assert match is not None, line
        detector, geometry, _, unit, values = match.groups()
        geometries.add(geometry)
        if geometry != "thesis (one camera)":
            continue
        key = (detector, "orientation" if unit == "deg" else "centroid")
        measured[key] = max(measured.get(key, 0.0), float(values.split()[systematic]))
    assert geometries == {"thesis (one camera)", "pair camera 1", "pair camera 2"}
    for method in MEASURING_METHODS:
        spec = spec_of(method)
        assert spec.target is not None
        name = str(spec.target.target)
        px, deg = spec.detector_floor
        assert measured[(name, "centroid")] <= px, (name, measured)
        if spec.uses_image_lines:
            assert measured[(name, "orientation")] <= deg, (name, measured)


def test_each_methods_floor_in_a_pair_is_its_measured_1_sigma_or_above_it() -> None:
    """A camera of a pair carries ``floor_in_pair``: at every size the floors are said to
    hold at (FLOOR_MEASURED_SIZES) it is never below the measured RMS's 95% interval, and a
    method's own pair floor (the ground's) lies within it, a 1-sigma, not a bound; the
    figure is the registry's (its floor column). At half size (320x240) the rows are said
    not held; point-sampled frames err more than supersampled ones there (the dot's
    regions in the tests' half-size scene: docs/figures/detector_floor.txt)."""
    _, rows = _floor_figure()
    row_re = re.compile(
        r"\s*(\w+)\s+(\d+x\d+(?: point-sampled)?)\s+(across px|orientation deg|centroid [xy] px)"
        r"\s+\d+\s+\d+\s+([\d.]+)\s+([\d.]+)-([\d.]+)\s+([\d.]+)\s+(.+)"
    )
    seen: dict[tuple[str, str, str], tuple[float, float, float, float, str]] = {}
    for line in rows:
        match = row_re.fullmatch(line)
        assert match is not None, line
        method, size, error, rms, lo, hi, floor, said = match.groups()
        seen[(method, size, error)] = (float(rms), float(lo), float(hi), float(floor), said)
    sizes = [f"{w}x{h}" for w, h in FLOOR_MEASURED_SIZES]
    for method in MEASURING_METHODS:
        spec = spec_of(method)
        errors = ("across px", "orientation deg") if spec.uses_image_lines else (
            "centroid x px", "centroid y px")  # fmt: skip
        floors = spec.floor_in_pair if spec.uses_image_lines else (spec.floor_in_pair[0],) * 2
        for size in sizes:
            for error, floor in zip(errors, floors, strict=True):
                rms, lo, hi, written, said = seen[(method.value, size, error)]
                assert written == pytest.approx(floor), (method, size, error)
                assert lo <= rms <= hi
                assert floor >= lo, (method, size, error, said)  # never narrower
                if spec.pair_floor is not None:
                    assert floor <= hi, (method, size, error)  # the 1-sigma
                    assert said == "1-sigma"
    assert "320x240" not in sizes
    assert all(v[4].startswith("not held: ") for k, v in seen.items() if k[1] == "320x240")
    for error in ("centroid x px", "centroid y px"):
        sampled = seen[("point", "320x240 point-sampled", error)][0]
        assert sampled > 1.3 * seen[("point", "320x240", error)][0]
