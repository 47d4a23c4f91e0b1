"""values: the one home of the checks every entry point shares."""

from __future__ import annotations

import numpy as np
import pytest

from twopose.errors import InputValueError
from twopose.values.checks import camera_id, finite, index, numbers, parse_number, vec3


def test_numbers_accept_lists_tuples_arrays_and_numpy_scalars() -> None:
    assert vec3([1, 2.5, np.float32(3)], "t") == (1.0, 2.5, 3.0)
    assert numbers(np.array([4.0, 5.0]), 2, "p") == (4.0, 5.0)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (None, "list of 3 numbers"),
        (1.0, "list of 3 numbers"),
        (np.array(1.0), "list of 3 numbers"),  # a 0-d array is not three numbers
        ("1 2 3", "list of 3 numbers"),
        ({"x": 1}, "list of 3 numbers"),
        ([1, 2], "got 2"),
        ([1, 2, True], "must be a number"),
        ([1, 2, "3"], "must be a number"),
        ([1, 2, float("nan")], "finite"),
        ([1, 2, 10**400], "too large"),
    ],
)
def test_bad_vectors_name_what_is_wrong(value: object, message: str) -> None:
    with pytest.raises(InputValueError, match=message):
        vec3(value, "t")


def test_scalars_indices_and_camera_ids() -> None:
    assert finite(2, "f", positive=True) == 2.0
    with pytest.raises(InputValueError, match="positive"):
        finite(0.0, "f", positive=True)
    assert index(np.int64(3), "trial") == 3
    for bad in (-1, 1.0, True):
        with pytest.raises(InputValueError, match="whole number"):
            index(bad, "trial")
    assert camera_id("cam_0-a") == "cam_0-a"
    with pytest.raises(InputValueError, match="camera id"):
        camera_id("cam 0")


@pytest.mark.parametrize(
    ("text", "value"),
    [("10", 10.0), ("-1.5", -1.5), (" +2e-3 ", 0.002), (".5", 0.5), ("5.", 5.0), ("-0", -0.0)],
)
def test_a_typed_number_is_ascii_digits_a_sign_a_point_an_exponent(text: str, value: float) -> None:
    assert parse_number(text, "x") == value


@pytest.mark.parametrize(
    "text",
    # Full-width 525 and Arabic-Indic 3, written as escapes (they look like digits).
    [
        "1_0",
        "\uff15\uff12\uff15",
        "\u0663",
        "1e",
        "e5",
        "--1",
        "1.2.3",
        "0x10",
        "inf",
        "nan",
        "1,5",
        "1 0",
    ],
)
def test_python_float_grammar_beyond_ascii_is_refused(text: str) -> None:
    """Python's float() reads 1_0 as 10 and full-width or Arabic-Indic digits as digits
    (issue 44): a typed pose or precision means none of them."""
    with pytest.raises(InputValueError, match=r"is not a number|finite"):
        parse_number(text, "x")
