"""Decoding images safely: the header is read first.

A small file that declares a huge image is refused before a byte of pixels is allocated.

Every image twopose decodes (session frames, ``detect`` inputs, ``images:`` sources) goes
through :func:`decode_image`.
"""

from __future__ import annotations

import io
import os

import numpy as np
from numpy.typing import NDArray

from twopose.errors import InputValueError

__all__ = ["decode_image", "image_size", "max_image_pixels"]


def max_image_pixels() -> int:
    """The largest image decoded, in pixels.

    The largest image decoded (pixels): 50 MP (above every camera the method uses, about 150
    MB decoded), or ``TWOPOSE_MAX_IMAGE_MPIX`` megapixels.
    """
    try:
        megapixels = float(os.environ.get("TWOPOSE_MAX_IMAGE_MPIX", "50"))
    except ValueError:
        megapixels = 50.0
    return int(megapixels * 1_000_000)


def image_size(data: bytes, what: str) -> tuple[int, int]:
    """(width, height) from the image's header, without decoding its pixels."""
    # A session's frames are JPEG or PNG: their header read here costs a few microseconds
    # a frame, against ~0.1 ms for Pillow's (every frame of a replay pays it). Anything
    # else, or a header this does not understand, is Pillow's to read or refuse.
    size = _jpeg_size(data) or _png_size(data)
    if size is not None:
        return size
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(io.BytesIO(data)) as img:
            width, height = img.size
    except Image.DecompressionBombError as err:  # Pillow's own header check, > ~179 MP
        raise InputValueError(
            f"{what} declares an image over the limit of {max_image_pixels() / 1e6:g} MP ({err})"
        ) from err
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as err:
        raise InputValueError(f"{what} is not a readable image ({err})") from err
    return int(width), int(height)


#: JPEG markers that stand alone (no length follows): TEM, RST0-7, SOI.
_STANDALONE = frozenset({0x01, *range(0xD0, 0xD9)})
#: Start-of-frame markers (they give the size): C0-CF but DHT (C4), JPG (C8) and DAC (CC).
_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    """A JPEG's (width, height) from its start-of-frame segment, or None.

    None: not a JPEG, a size of 0, or a header cut short (left to Pillow).
    """
    if data[:2] != b"\xff\xd8":
        return None
    i, n = 2, len(data)
    while i + 4 <= n:
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in _STANDALONE:
            i += 2
            continue
        if marker in _SOF:
            if i + 9 > n:
                return None
            height = int.from_bytes(data[i + 5 : i + 7], "big")
            width = int.from_bytes(data[i + 7 : i + 9], "big")
            return (width, height) if width and height else None
        if marker in (0xD9, 0xDA):  # the image ends, or its data starts, before a size
            return None
        i += 2 + int.from_bytes(data[i + 2 : i + 4], "big")
    return None


def _png_size(data: bytes) -> tuple[int, int] | None:
    """A PNG's (width, height) from its IHDR chunk, or None."""
    if data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR" or len(data) < 24:
        return None
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    return (width, height) if width and height else None


def decode_image(
    data: bytes, what: str, expected_size: tuple[int, int] | None = None
) -> NDArray[np.uint8]:
    """An encoded image as an (H, W, 3) BGR uint8 array (OpenCV's order).

    Raises :class:`InputValueError` (naming ``what``) if it is not an image, declares more
    than :func:`max_image_pixels`, differs from ``expected_size`` (width, height), or does
    not decode.
    """
    import cv2

    width, height = image_size(data, what)
    if expected_size is not None and (width, height) != tuple(expected_size):
        raise InputValueError(
            f"{what} is {width}x{height}, but its camera's calibration is "
            f"{expected_size[0]}x{expected_size[1]}"
        )
    limit = max_image_pixels()
    if width * height > limit:
        raise InputValueError(
            f"{what} declares {width}x{height} pixels, over the limit of "
            f"{limit / 1e6:g} MP (TWOPOSE_MAX_IMAGE_MPIX raises it)"
        )
    try:
        img = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    except cv2.error as err:
        raise InputValueError(f"{what} could not be decoded ({err.msg.strip()})") from err
    if img is None:
        raise InputValueError(f"{what} could not be decoded")
    return np.asarray(img, dtype=np.uint8)
