"""The output folder of a run: created safely, and re-runs replace only their own files.

Every file a run writes into ``--out`` is listed in ``.twopose-outputs.json`` there. The next
run into the same folder first removes the files that list names (and only those: never a
file it did not write), so no stale per-session file of an earlier run survives with
numbering that no longer matches.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path

from twopose.errors import InputValueError, TwoposeError

__all__ = ["MANIFEST_NAME", "OutputFolder"]

MANIFEST_NAME = ".twopose-outputs.json"


class OutputFolder:
    """A run's ``--out`` folder (see the module docstring)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    @classmethod
    def prepare(cls, path: str | Path) -> OutputFolder:
        """Create the folder (and parents) and remove what the previous run wrote there.

        Raises
        ------
        InputValueError
            ``path`` is an existing file, or cannot be created or written to.
        """
        folder = Path(path)
        if folder.exists() and not folder.is_dir():
            raise InputValueError(f"--out {folder} is a file; give a folder for the results")
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise InputValueError(
                f"cannot create the output folder {folder}: {err.strerror or err}"
            ) from err
        if not os.access(folder, os.W_OK | os.X_OK):
            raise InputValueError(f"cannot write into the output folder {folder}")
        out = cls(folder)
        out._remove_previous()
        return out

    def _manifest(self) -> Path:
        return self.path / MANIFEST_NAME

    def previous_outputs(self) -> list[str]:
        """The file names the previous run listed (an unreadable list counts as empty)."""
        try:
            names = json.loads(self._manifest().read_text(encoding="utf-8"))["files"]
        except (OSError, ValueError, KeyError, TypeError):
            return []
        return [n for n in names if isinstance(n, str) and _plain_name(n)]

    def _remove_previous(self) -> None:
        for name in self.previous_outputs():
            try:
                (self.path / name).unlink(missing_ok=True)
            except OSError as err:
                raise TwoposeError(
                    f"cannot replace {self.path / name} from an earlier run: {err.strerror}"
                ) from err
        self._manifest().unlink(missing_ok=True)

    def record(self, names: Iterable[str]) -> None:
        """List the files this run wrote (those that exist), for the next run to replace."""
        present = sorted({n for n in names if _plain_name(n) and (self.path / n).is_file()})
        text = json.dumps({"written_by": "twopose-analyze run", "files": present}, indent=1)
        self._manifest().write_text(text + "\n", encoding="utf-8")


def _plain_name(name: str) -> bool:
    """A file name directly inside the folder (a tampered list cannot reach elsewhere)."""
    return bool(name) and name not in (".", "..", MANIFEST_NAME) and Path(name).name == name
