"""Decoding images safely: the header is read first.

A small file that declares a huge image is refused before a byte of pixels is allocated.

Every image twopose decodes (session frames, ``detect`` inputs, ``images:`` sources) goes
through :func:`decode_image`.
"""

from __future__ import annotations

import io

import numpy as np
from numpy.typing import NDArray

from twopose.errors import InputValueError

__all__ = ["decode_image", "image_size", "max_image_pixels"]


def max_image_pixels() -> int:
    """The largest image decoded, in pixels.

    The largest image decoded (pixels): 50 MP (above every camera the method uses, about 150
    MB decoded), or ``TWOPOSE_MAX_IMAGE_MPIX`` megapixels (:data:`twopose.values.environment.
    MAX_IMAGE_MPIX`, in the analysis cache's key).
    """
    from twopose.values.environment import MAX_IMAGE_MPIX

    megapixels = MAX_IMAGE_MPIX.read()
    assert megapixels is not None  # a number with a default
    return int(megapixels * 1_000_000)


def image_size(data: bytes, what: str) -> tuple[int, int]:
    """(width, height) from the image's header, without decoding its pixels."""
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
