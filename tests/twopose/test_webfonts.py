"""The fonts the pages carry (twopose/display/fonts.py, issue 53): each shipped file is the
subset it says (every character of its set that DejaVu has, no hinting instructions), its
licence is beside it, the package installs them, and the CSS names each one."""

from __future__ import annotations

import base64
import fnmatch
import io
import re
import tomllib
from pathlib import Path

import matplotlib
import pytest
from fontTools.ttLib import TTFont

from twopose.display import fonts as webfonts

REPO = Path(__file__).resolve().parents[2]
FOLDER = REPO / "twopose" / "fonts"
SOURCE = Path(matplotlib.__file__).parent / "mpl-data" / "fonts" / "ttf"
CODEPOINTS = {
    webfonts.SANS_FAMILY: webfonts.SANS_CODEPOINTS,
    webfonts.MONO_FAMILY: webfonts.MONO_CODEPOINTS,
}


@pytest.mark.parametrize("font", webfonts.FONTS, ids=lambda f: f.file)
def test_each_font_is_the_subset_it_says_without_hinting(font: webfonts.WebFont) -> None:
    shipped = TTFont(io.BytesIO(webfonts.font_bytes(font.file)))
    assert shipped.flavor == "woff"
    source = TTFont(SOURCE / webfonts.SOURCES[font.file], lazy=True)
    codepoints = CODEPOINTS[font.family]
    has = set(shipped.getBestCmap())
    assert has == set(source.getBestCmap()) & codepoints  # nothing missing, nothing more
    assert ord("±") in has
    assert ord("…") in has
    assert ord("A") in has
    if font.family == webfonts.SANS_FAMILY:
        assert {ord(c) for c in "≤≥\u2212→▲△○σµ°·“”"} <= has  # what the pages write
    # No hinting: a glyph is drawn alike whatever hinting a machine's settings ask for.
    assert not {"fpgm", "prep", "cvt "} & set(shipped.keys())
    assert shipped["OS/2"].usWeightClass == font.weight
    assert shipped["name"].getDebugName(1) == source["name"].getDebugName(1)
    assert "Bitstream" not in font.family
    assert "Vera" not in font.family


def test_the_licence_is_beside_the_fonts_and_the_package_installs_both() -> None:
    licence = (FOLDER / "LICENSE-DejaVu.txt").read_text(encoding="utf-8")
    assert "Bitstream Vera" in licence
    assert "DejaVu changes are in public domain" in licence
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = pyproject["tool"]["setuptools"]["package-data"]["twopose"]
    shipped = {p.name for p in FOLDER.iterdir()}
    assert shipped == {f.file for f in webfonts.FONTS} | {"LICENSE-DejaVu.txt"}
    for name in shipped:
        assert any(fnmatch.fnmatch(f"fonts/{name}", p) for p in patterns), name


def test_the_css_carries_every_font_or_names_where_it_is_served() -> None:
    embedded = webfonts.font_face_css()
    rules = re.findall(r"@font-face\{([^}]*)\}", embedded)
    assert len(rules) == len(webfonts.FONTS)
    for rule, font in zip(rules, webfonts.FONTS, strict=True):
        assert f"font-family:'{font.family}'" in rule
        assert f"font-weight:{font.weight}" in rule
        data = re.search(r"url\('data:font/woff;base64,([^']*)'\)", rule)
        assert data is not None
        assert base64.b64decode(data.group(1)) == webfonts.font_bytes(font.file)
    served = webfonts.font_face_css(lambda file: f"/fonts/{file}")
    assert "url('/fonts/twopose-sans-bold.woff')" in served
    assert "data:" not in served
    assert webfonts.SANS.startswith('"twopose Sans"')
    assert webfonts.SANS.endswith("sans-serif")
    with pytest.raises(KeyError):
        webfonts.font_bytes("../__init__.py")


def test_the_shipped_fonts_are_what_make_fonts_writes(tmp_path: Path) -> None:
    """``python -m twopose.display.fonts twopose/fonts/`` writes the committed files, byte for
    byte (a character set changed without the fonts written again fails here)."""
    webfonts.make_fonts(tmp_path)
    for name in [f.file for f in webfonts.FONTS] + ["LICENSE-DejaVu.txt"]:
        assert (tmp_path / name).read_bytes() == (FOLDER / name).read_bytes(), name
