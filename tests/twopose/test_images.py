"""images: headers checked before a pixel is decoded."""

from __future__ import annotations

import resource

import cv2
import numpy as np
import pytest

from tests.helpers import jpeg_declaring
from twopose.errors import InputValueError
from twopose.images import decode_image, image_size


def test_a_small_file_declaring_a_huge_image_is_refused_before_decoding() -> None:
    bomb = jpeg_declaring(32000, 32000)
    assert len(bomb) < 1000
    assert image_size(jpeg_declaring(9000, 8000), "big") == (9000, 8000)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(InputValueError, match="over the limit of 50 MP"):
        decode_image(bomb, "bomb")
    with pytest.raises(InputValueError, match="9000x8000 pixels, over the limit of 50 MP"):
        decode_image(jpeg_declaring(9000, 8000), "big")
    grown_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown_kib < 50_000  # 32000^2 x 3 bytes would be ~3 GB


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (b"", "not a readable image"),
        (b"\x89PNG\r\n\x1a\n garbage", "not a readable image"),
        (jpeg_declaring(640, 480)[:40], "not a readable image|could not be decoded"),
    ],
)
def test_empty_or_broken_data_is_a_clear_error(data: bytes, message: str) -> None:
    with pytest.raises(InputValueError, match=message):
        decode_image(data, "frame 3")


def test_the_size_must_match_the_calibration() -> None:
    _ok, png = cv2.imencode(".png", np.zeros((48, 64, 3), np.uint8))
    assert decode_image(png.tobytes(), "f", (64, 48)).shape == (48, 64, 3)
    with pytest.raises(InputValueError, match="is 64x48, but its camera's calibration is 640x480"):
        decode_image(png.tobytes(), "f", (640, 480))


def test_the_pixel_limit_is_read_when_decoding(monkeypatch: pytest.MonkeyPatch) -> None:
    _ok, png = cv2.imencode(".png", np.zeros((48, 64, 3), np.uint8))
    monkeypatch.setenv("TWOPOSE_MAX_IMAGE_MPIX", "0.001")  # 1000 pixels
    with pytest.raises(InputValueError, match=r"64x48 pixels, over the limit of 0\.001 MP"):
        decode_image(png.tobytes(), "f")
    monkeypatch.setenv("TWOPOSE_MAX_IMAGE_MPIX", "many")  # a typo keeps the default
    assert decode_image(png.tobytes(), "f").shape == (48, 64, 3)


@pytest.mark.parametrize(
    ("ext", "params"),
    [
        (".jpg", []),
        (".jpg", [cv2.IMWRITE_JPEG_PROGRESSIVE, 1]),  # its size in an SOF2 segment
        (".jpg", [cv2.IMWRITE_JPEG_OPTIMIZE, 1, cv2.IMWRITE_JPEG_RST_INTERVAL, 4]),
        (".png", []),
    ],
)
def test_the_header_read_here_is_pillows(ext: str, params: list[int]) -> None:
    """image_size reads a JPEG's or PNG's header itself (a replay pays it every frame): the
    same size as Pillow's, also after an application segment and fill bytes."""
    import io

    from PIL import Image

    for width, height in ((64, 48), (641, 479), (7, 300)):
        _ok, buf = cv2.imencode(ext, np.zeros((height, width, 3), np.uint8), params)
        data = buf.tobytes()
        if ext == ".jpg":  # an APP1 segment and two fill bytes before the rest
            data = data[:2] + b"\xff\xe1\x00\x06Exif" + b"\xff\xff" + data[2:]
        with Image.open(io.BytesIO(data)) as img:
            assert image_size(data, "f") == img.size == (width, height)
        assert decode_image(data, "f").shape == (height, width, 3)
