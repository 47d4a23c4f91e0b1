"""images: headers checked before a pixel is decoded."""

from __future__ import annotations

import resource

import cv2
import numpy as np
import pytest

from tests.helpers import jpeg_declaring
from twopose.camera.images import decode_image, image_size
from twopose.errors import InputValueError


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
