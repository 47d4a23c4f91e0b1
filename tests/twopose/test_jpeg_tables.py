"""A webcam's MJPG frame without Huffman tables: stored as a standard JPEG, pixels unchanged.

The frames are real JPEGs: OpenCV encodes them with the standard tables (its default, no
optimized tables), then their DHT segments are cut out, as a UVC webcam sends them.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from twopose.camera.jpeg_tables import STANDARD_TABLES, huffman_tables, with_huffman_tables


def _encoded(image: NDArray[np.uint8], quality: int = 85, sampling: int | None = None) -> bytes:
    params = [cv2.IMWRITE_JPEG_QUALITY, quality]
    if sampling is not None:
        params += [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, sampling]
    ok, data = cv2.imencode(".jpg", image, params)
    assert ok
    return bytes(data)


def _segments(data: bytes) -> list[tuple[int, bytes]]:
    """Every marker segment before the first scan: (marker, whole segment)."""
    out, at = [], 2
    while data[at + 1] != 0xDA:
        end = at + 2 + int.from_bytes(data[at + 2 : at + 4], "big")
        out.append((data[at + 1], data[at:end]))
        at = end
    return out


def _without_dht(data: bytes) -> bytes:
    """``data`` with its DHT segments cut out (what an MJPG webcam sends)."""
    kept = b"".join(seg for marker, seg in _segments(data) if marker != 0xC4)
    scan = len(data[:2]) + sum(len(seg) for _, seg in _segments(data))
    return data[:2] + kept + data[scan:]


def _tables(data: bytes) -> set[tuple[int, int]] | None:
    """The Huffman tables ``data`` defines before its scan (None: not walkable)."""
    found = huffman_tables(data)
    return None if found is None else found[0]


def _decoded(data: bytes) -> NDArray[np.uint8]:
    image = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    assert image is not None
    return np.asarray(image)


def _image(seed: int, shape: tuple[int, ...] = (48, 64, 3)) -> NDArray[np.uint8]:
    rng = np.random.default_rng(seed)
    noise = (rng.random(shape) * 255).astype(np.uint8)
    return np.asarray(cv2.GaussianBlur(noise, (5, 5), 2), dtype=np.uint8)


def test_the_standard_tables_are_those_libjpeg_encodes_with() -> None:
    """The constants are T.81 Annex K.3's: OpenCV's (libjpeg's) default tables, byte for byte."""
    tables: dict[tuple[int, int], tuple[bytes, bytes]] = {}
    for marker, seg in _segments(_encoded(_image(0))):
        body, k = seg[4:], 0
        while marker == 0xC4 and k < len(body):
            n = sum(body[k + 1 : k + 17])
            tables[(body[k] >> 4, body[k] & 15)] = (body[k + 1 : k + 17], body[k + 17 : k + 17 + n])
            k += 17 + n
    assert tables == STANDARD_TABLES


def test_a_frame_without_huffman_tables_gets_the_standard_ones_pixels_unchanged() -> None:
    original = _encoded(_image(1))
    mjpg = _without_dht(original)
    assert b"\xff\xc4" not in mjpg[: mjpg.index(b"\xff\xda")]  # really no DHT
    assert _tables(mjpg) == set()
    fixed = with_huffman_tables(mjpg)
    assert _tables(fixed) == set(STANDARD_TABLES)
    assert len(fixed) == len(mjpg) + 420  # one DHT segment: ffmpeg's mjpeg2jpeg's size
    # only inserted: the bytes before and after it are the frame's own
    at = mjpg.index(b"\xff\xda")
    assert fixed[:at] == mjpg[:at]
    assert fixed[at + 420 :] == mjpg[at:]
    assert np.array_equal(_decoded(fixed), _decoded(original))
    import io

    from PIL import Image  # another decoder reads the same pixels

    with Image.open(io.BytesIO(fixed)) as pil:
        assert np.array_equal(np.asarray(pil)[..., ::-1], _decoded(original))


def test_a_frame_with_its_tables_or_no_jpeg_is_left_as_it_is() -> None:
    whole = _encoded(_image(2))
    assert with_huffman_tables(whole) is whole
    png = bytes(cv2.imencode(".png", _image(2))[1])
    for other in (b"", b"\xff\xd8", png, whole[:40], b"\xff\xd8\xff\xc4\x00\x30"):
        assert with_huffman_tables(other) == other  # nothing guessed


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    quality=st.integers(5, 100),
    sampling=st.sampled_from([None, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444,
                              cv2.IMWRITE_JPEG_SAMPLING_FACTOR_422]),
    gray=st.booleans(),
    width=st.integers(8, 80),
)  # fmt: skip
def test_any_frame_cut_of_its_tables_decodes_as_it_was(
    seed: int, quality: int, sampling: int | None, gray: bool, width: int
) -> None:
    shape = (24, width) if gray else (24, width, 3)
    original = _encoded(_image(seed, shape), quality, sampling)
    fixed = with_huffman_tables(_without_dht(original))
    assert np.array_equal(_decoded(fixed), _decoded(original))
    assert with_huffman_tables(fixed) == fixed  # once is enough


def test_a_session_stores_the_camera_s_mjpg_as_a_standard_jpeg(tmp_path: Path) -> None:
    """The recorder stores a camera's own bytes (``Stream.add_encoded``): a frame without
    tables is stored with them, and every reader of the session (the replay, Foxglove's
    CompressedImage, the analysis' results file) gets a standard JPEG."""
    from tests.twopose.format.pair_examples import pair_cameras
    from twopose.format.entries import SessionInfo
    from twopose.format.reader import SessionReader
    from twopose.format.streams import read_pair_session
    from twopose.format.writer import SessionWriter
    from twopose.methods.specs import Method
    from twopose.pair.motion import thesis_pair
    from twopose.values.units import Units

    pair = thesis_pair()
    image = _image(3, (480, 640, 3))
    original = _encoded(image)
    mjpg = _without_dht(original)
    info = SessionInfo(method=Method.POINT, units=Units.IN, camera_ids=("cam1", "cam2"))
    path = tmp_path / "mjpg.mcap"
    with (
        SessionWriter(path, info, pair_cameras(pair), pair=pair) as writer,
        writer.stream(1) as stream,
    ):
        stream.add_encoded("cam1", mjpg, 10**9)
        stream.add_encoded("cam2", mjpg, 10**9 + 5)
    with SessionReader(path) as reader:
        trial = read_pair_session(reader).trials[0]
        stored = [f.data for s in trial.cameras for f in s.frames()]
        replayed = list(trial.camera1.images())
    assert len(stored) == 2
    for data in stored:
        assert _tables(data) == set(STANDARD_TABLES)
    assert np.array_equal(replayed[0], _decoded(original))
    # a session recorded before (its frames as the camera sent them): the analysis' results
    # file for Foxglove carries them through the same message, standard
    from twopose.format.messages import image_message

    assert _tables(image_message("cam1", mjpg, "jpeg", 1).data) == set(STANDARD_TABLES)
    png = bytes(cv2.imencode(".png", image)[1])
    assert image_message("cam1", png, "png", 1).data == png
