"""entries: every typed entry round-trips through its schema-checked JSON."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.twopose.format.pair_examples import PAIR_SESSION_EXAMPLES
from twopose.errors import SessionFormatError
from twopose.format.entries import (
    TYPED_ENTRIES,
    CaptureDecision,
    CaptureWindow,
    GroundTruth,
    GuidanceRecord,
    Note,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
    TruePose,
    decode_entry,
    encode_entry,
)
from twopose.methods.specs import Method
from twopose.methods.targets import BoardPlacement
from twopose.values.units import Units

EXAMPLES = [
    SessionInfo(  # the first of its kind has every field (the schema's order is checked on it)
        method=Method.BOARD,
        units=Units.IN,
        operator="Ada",
        simulated=True,
        intrinsics_sigma={"cam0": {"fx": 0.93, "cy": 1.07}},
        board=BoardPlacement(inner_corners=(9, 6), square=0.75, first_corner=(-3, 8.125, 24)),
        session_id="0123456789abcdef0123456789abcdef",
        continues_after_trial=2,
        continues_file="S.mcap",
        continues_sha256="ab" * 32,
        part_id="fedcba9876543210fedcba9876543210",
        continues_part="00112233445566778899aabbccddeeff",
        continues_branch="B",
        guidance=GuidanceRecord(  # format 1.5, each given value with its text
            target95=0.8,
            max_poses=5,
            min_gain=0.25,
            reach=2.5,
            spacing=0.25,
            target_distance=11.0,
            given={"reach": "2.50", "min_gain": "2.5e-1"},
        ),
        clocks={"cam0": "driver"},  # format 1.6
    ),
    SessionInfo(
        method=Method.GROUND,
        units=Units.MM,
        operator="Ada",
        simulated=True,
        intrinsics_sigma={"cam0": {"fx": 0.93, "cy": 1.07}},
    ),
    PoseEntry(
        trial=2,
        pose=1,
        camera_id="cam0",
        t_grid=(1.5, 0.0, -2.0),
        r_deg=(0.0, 5.0, 0.0),
        translation_resolution=0.1,
        rotation_resolution_deg=0.25,
        capture=4,
    ),
    CaptureWindow(
        trial=2,
        pose=1,
        camera_id="cam0",
        start_ns=10,
        end_ns=20,
        n_frames=5,
        status="incomplete",
        reason="camera stopped",
        dropped_frames=3,
        capture=4,
    ),
    CaptureDecision(
        capture=4, trial=2, pose=1, camera_id="cam0", decision="discard", reason="redo"
    ),
    PlaneEntry(offset=9.625),
    GroundTruth(trial=1, kind="line", points_grid=((0.0, 1.0, 2.0), (3.0, 4.0, 5.0))),
    Note(text="glare", trial=3),
    Note(text="session-wide"),
    SimulationTruth(
        trial=1,
        poses=(TruePose(pose=1, camera_id="cam0", t_grid=(0.1, 0.0, 0.0), r_deg=(0.0, 0.0, 0.0)),),
        kind="point",
        points_grid=((1, 2, 3),),
        rig=(0.8, -0.5, 0.3, 0.3, 0.2, 0.4, 1.03, 0.0, 0.0, 1.0, 0.0),  # the rig's constants
    ),
    *PAIR_SESSION_EXAMPLES,
]


@pytest.mark.parametrize("entry", EXAMPLES, ids=lambda e: type(e).__name__)
def test_every_entry_round_trips_through_its_json(entry: object) -> None:
    payload = encode_entry(entry)  # type: ignore[arg-type]
    assert decode_entry(type(entry).SCHEMA_NAME, payload) == entry  # type: ignore[attr-defined]


@pytest.mark.parametrize("cls", TYPED_ENTRIES, ids=lambda c: c.__name__)
def test_schema_properties_are_the_declared_fields_in_order(cls: type[Any]) -> None:
    keys = [
        f.metadata["json"].split(".")[0] for f in dataclasses.fields(cls) if "json" in f.metadata
    ]
    assert list(cls.JSON_SCHEMA["properties"]) == list(dict.fromkeys(keys))
    assert set(cls.JSON_SCHEMA["required"]) <= set(cls.JSON_SCHEMA["properties"])
    example = next(e for e in EXAMPLES if type(e) is cls)
    assert list(example.to_json()) == list(cls.JSON_SCHEMA["properties"])


@pytest.mark.parametrize(
    ("sigma", "message"),
    [
        ({"cam9": {"fx": 1.0}}, "unknown camera"),
        ({"cam0": {"focal": 1.0}}, "focal"),
        ({"cam0": {"fx": -1.0}}, "fx"),
        ({"cam0": {"fx": float("nan")}}, "fx"),
    ],
)
def test_a_session_refuses_a_malformed_intrinsics_sigma(sigma: object, message: str) -> None:
    from twopose.errors import InputValueError

    with pytest.raises(InputValueError, match=message):
        SessionInfo(method=Method.POINT, units=Units.IN, intrinsics_sigma=sigma)  # type: ignore[arg-type]


def test_a_board_session_and_only_a_board_session_has_a_board() -> None:
    from twopose.errors import InputValueError

    board = BoardPlacement(inner_corners=(9, 6), square=0.75, first_corner=(-3, 8.125, 24))
    with pytest.raises(InputValueError, match="a board session needs its board"):
        SessionInfo(method=Method.BOARD, units=Units.IN)
    with pytest.raises(InputValueError, match="only a board session has one"):
        SessionInfo(method=Method.POINT, units=Units.IN, board=board)
    data = json.loads(encode_entry(SessionInfo(method=Method.BOARD, units=Units.IN, board=board)))
    assert data["board"] == {
        "inner_corners": [9, 6],
        "square": 0.75,
        "first_corner": [-3.0, 8.125, 24.0],
    }
    data["board"]["inner_corners"] = [9, 1]  # a file's board that is no board
    with pytest.raises(SessionFormatError, match="inner_corners"):
        decode_entry(SessionInfo.SCHEMA_NAME, json.dumps(data).encode())


def test_a_1_0_entry_leaves_the_capture_number_out() -> None:
    """Format 1.0 entries (no capture number) encode exactly as 1.0 wrote them."""
    assert "capture" not in json.loads(
        encode_entry(PoseEntry(trial=1, pose=2, camera_id="cam0", t_grid=(1, 2, 3)))
    )
    window = CaptureWindow(trial=1, pose=2, camera_id="cam0", start_ns=0, end_ns=1, n_frames=2)
    assert "capture" not in json.loads(encode_entry(window))
    assert decode_entry(CaptureWindow.SCHEMA_NAME, encode_entry(window)) == window


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_capture_numbers_start_at_one(bad: object) -> None:
    from twopose.errors import InputValueError

    with pytest.raises(InputValueError, match="capture"):
        CaptureDecision(capture=bad, trial=1, pose=1, camera_id="cam0", decision="accept")  # type: ignore[arg-type]
    with pytest.raises(InputValueError, match="capture"):
        PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0), capture=bad)  # type: ignore[arg-type]


def test_a_decision_is_accept_or_discard() -> None:
    from twopose.errors import InputValueError

    with pytest.raises(InputValueError, match="accept or discard"):
        CaptureDecision(capture=1, trial=1, pose=1, camera_id="cam0", decision="maybe")  # type: ignore[arg-type]
    with pytest.raises(SessionFormatError, match="decision"):
        decode_entry(
            CaptureDecision.SCHEMA_NAME,
            b'{"capture":1,"trial":1,"pose":1,"camera":"c","decision":"ok"}',
        )


def test_pose_entry_json_is_the_documented_shape() -> None:
    data = json.loads(encode_entry(PoseEntry(trial=1, pose=2, camera_id="cam0", t_grid=(1, 2, 3))))
    assert data == {
        "trial": 1,
        "pose": 2,
        "camera": "cam0",
        "translation": [1.0, 2.0, 3.0],
        "rotation_deg": [0.0, 0.0, 0.0],
        "resolution": {"translation": 0.0625, "rotation_deg": 0.5},
    }


def test_unknown_fields_are_ignored_and_missing_optional_ones_default() -> None:
    payload = json.dumps(
        {"format_version": "1.3", "method": "point", "units": "in", "camera_ids": ["a"], "new": 1}
    ).encode()
    info = decode_entry("twopose.Session", payload)
    assert info == SessionInfo(
        format_version="1.3", method=Method.POINT, units=Units.IN, camera_ids=("a",)
    )


@pytest.mark.parametrize(
    "payload",
    [b"{", b'{"trial": 1}', b'{"trial": -1, "kind": "point", "points": [[0, 0, 0]]}'],
)
def test_invalid_json_is_a_format_error(payload: bytes) -> None:
    with pytest.raises(SessionFormatError):
        decode_entry("twopose.GroundTruth", payload)


finite = st.floats(allow_nan=False, allow_infinity=False, width=32)


@given(
    trial=st.integers(0, 10**6),
    pose=st.integers(0, 100),
    t=st.tuples(finite, finite, finite),
    r=st.tuples(finite, finite, finite),
    res=st.floats(1e-6, 10.0),
)
def test_pose_entries_round_trip_for_any_finite_values(
    trial: int,
    pose: int,
    t: tuple[float, float, float],
    r: tuple[float, float, float],
    res: float,
) -> None:
    entry = PoseEntry(
        trial=trial,
        pose=pose,
        camera_id="cam_1",
        t_grid=t,
        r_deg=r,
        translation_resolution=res,
        rotation_resolution_deg=res,
    )
    assert decode_entry(PoseEntry.SCHEMA_NAME, encode_entry(entry)) == entry
