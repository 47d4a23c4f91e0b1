"""A package's public names loaded on first use (PEP 562), written once for the three.

``import twopose`` (or ``recorder``, ``analysis``) loads no NumPy or OpenCV, and
``twopose.Camera`` imports its module when first read.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, homes: Mapping[str, str], public: list[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module ``__getattr__`` and ``__dir__`` of ``package``.

    Each name of ``homes`` is read from its home module on first use; ``public`` (the
    package's ``__all__``) is listed by ``dir()``.
    """

    def __getattr__(name: str) -> Any:  # noqa: N807 - the module hook's name
        if name in homes:
            return getattr(importlib.import_module(homes[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:  # noqa: N807 - the module hook's name
        return sorted(set(importlib.import_module(package).__dict__) | set(public))

    return __getattr__, __dir__
