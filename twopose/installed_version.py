"""The installed twopose's version, read from its metadata when first asked for.

``twopose.__version__`` (and ``recorder.__version__``) load it from here on first use:
``importlib.metadata`` costs a tenth of a second to import, and ``twopose-record`` must
handle a stop signal from its first instruction on (:mod:`recorder.cli.command`).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

__all__ = ["__version__"]

try:
    __version__ = version("twopose")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0.0.0+unknown"
