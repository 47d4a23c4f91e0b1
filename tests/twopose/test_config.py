"""twopose.values.toml directly: TOML becomes a typed, validated dataclass, and each bad key or
value is an error of the caller's class that names the key; an unreadable file says why."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import pytest

from twopose.errors import InputValueError, SceneError
from twopose.values.toml import build_dataclass, read_toml


@dataclass(frozen=True, kw_only=True)
class _Camera:
    f: float = 525.0
    size: tuple[int, int] = (640, 480)


@dataclass(frozen=True, kw_only=True)
class _Doc:
    name: str = "a"
    trials: int = 1
    live: bool = False
    target: Literal["point", "line"] = "point"
    poses: tuple[tuple[float, float, float], ...] = ()
    camera: _Camera = _Camera()


def test_a_full_table_builds_nested_and_converted_values() -> None:
    doc = build_dataclass(
        _Doc,
        {
            "name": "b",
            "trials": 3,
            "live": True,
            "target": "line",
            "poses": [[0, 0, 0], [1.5, 0, 2]],
            "camera": {"f": 500, "size": [1280, 720]},
        },
        "plan",
        InputValueError,
    )
    assert doc == _Doc(
        name="b",
        trials=3,
        live=True,
        target="line",
        poses=((0.0, 0.0, 0.0), (1.5, 0.0, 2.0)),
        camera=_Camera(f=500.0, size=(1280, 720)),
    )
    assert isinstance(doc.camera.f, float)
    assert build_dataclass(_Doc, {}, "plan", InputValueError) == _Doc()


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"nmae": "x"}, "plan: unknown key(s) nmae; known here: camera, live, name"),
        ({"camera": {"fx": 1}}, "unknown key(s) camera.fx"),
        ({"trials": 2.5}, "plan: trials must be a whole number, got 2.5"),
        ({"trials": True}, "trials must be a whole number"),
        ({"live": 1}, "plan: live must be true or false, got 1"),
        ({"name": 3}, "plan: name must be a string"),
        ({"target": "ground"}, "plan: target must be one of ['point', 'line'], got 'ground'"),
        ({"camera": {"f": float("nan")}}, "plan: camera.f must be a finite number, got nan"),
        ({"camera": {"f": "525"}}, "camera.f must be a finite number"),
        ({"camera": {"size": [640]}}, "plan: camera.size must have 2 items, got 1"),
        ({"camera": {"size": 640}}, "plan: camera.size must be a list, got 640"),
        ({"poses": [[0, 0, "x"]]}, "plan: poses[0][2] must be a finite number, got 'x'"),
        ({"camera": 5}, "plan: camera must be a table"),
    ],
)
def test_each_bad_value_names_its_key(data: dict[str, object], message: str) -> None:
    with pytest.raises(SceneError) as caught:
        build_dataclass(_Doc, data, "plan", SceneError)
    assert message in str(caught.value)


def test_read_toml_reads_a_file_and_says_why_it_cannot(tmp_path: Path) -> None:
    good = tmp_path / "good.toml"
    good.write_text('name = "x"\n[camera]\nf = 500.0\n')
    assert read_toml(good, "plan", InputValueError) == {"name": "x", "camera": {"f": 500.0}}
    bad = tmp_path / "bad.toml"
    bad.write_text("name = \n")
    with pytest.raises(InputValueError, match=r"plan .*bad.toml is not valid TOML"):
        read_toml(bad, "plan", InputValueError)
    latin = tmp_path / "latin.toml"
    latin.write_bytes(b'name = "\xe9"\n')
    with pytest.raises(InputValueError, match="is not UTF-8 text"):
        read_toml(latin, "plan", InputValueError)
    with pytest.raises(SceneError, match=r"cannot read scene file .*missing.toml"):
        read_toml(tmp_path / "missing.toml", "scene file", SceneError)
