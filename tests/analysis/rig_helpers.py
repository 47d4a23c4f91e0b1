"""What the rig tests share: the simulated rig, a session without trials, `rig` run through
the command line, and a session's rig data."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from typer.testing import CliRunner

from analysis.cli import app
from analysis.rig.data import RigData, prepare_trials
from analysis.session.pipeline import replay_views
from twopose.methods.specs import Method
from twopose.rig.constants import RigConstants
from twopose.values.units import Units

runner = CliRunner()


RIG = RigConstants(camera_offset=(0.3, 0.2, 0.4), mount_rotation_deg=(0.8, -0.5, 0.3))


def rig_data(path: Path) -> RigData:
    return prepare_trials(replay_views(path))


def empty_session(
    path: Path, method: Literal["point", "line", "ground"], units: str, ground: float | None = None
) -> Path:
    """A session without trials (what a recording that stopped at once leaves)."""
    from twopose.camera.model import Camera, Intrinsics
    from twopose.format.entries import PlaneEntry, SessionInfo
    from twopose.format.writer import SessionWriter

    camera = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    plane = PlaneEntry(offset=ground) if ground is not None else None
    info = SessionInfo(method=Method(method), units=Units(units))
    with SessionWriter(path, info, [camera], ground=plane):
        pass
    return path


def rig_values(path: Path) -> dict[str, object]:
    """The [rig] and [sigma] tables of a rig file (what `run --rig` reads, and the 1-sigma)."""
    import tomllib

    data = tomllib.loads(path.read_text())
    return {"rig": data["rig"], "sigma": data["sigma"]}


def rig_file(tmp_path: Path, *paths: Path) -> tuple[dict[str, object], str]:
    out = tmp_path / f"rig_{len(list(tmp_path.glob('rig_*.toml')))}.toml"
    result = runner.invoke(app, ["rig", *(str(p) for p in paths), "--out", str(out)])
    assert result.exit_code == 0, result.output
    return rig_values(out), result.output
