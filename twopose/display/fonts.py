"""The fonts the pages ship (the report, the comparison, the operator's console).

A page that names only ``sans-serif`` is drawn in whichever face the machine maps it to
(DejaVu Sans on one machine, Liberation Sans on the next, which a browser's recommended
packages bring): other widths, other line breaks, another picture. Our pages name their
own fonts instead and carry them: subsets of DejaVu Sans (regular, bold) and DejaVu Sans
Mono, cut from the fonts matplotlib ships by :func:`make_fonts` (the same bytes every
time: ``python -m twopose.display.fonts twopose/fonts/``) as WOFF files without hinting
instructions, so that a glyph is drawn the same whatever hinting a machine's settings ask
for. Their licence (the Bitstream Vera licence, DejaVu's changes in the public domain) is
``twopose/fonts/LICENSE-DejaVu.txt``; it allows subsets under names without "Bitstream",
"Vera" or "Arev". The report embeds them as ``data:`` URIs (one file that opens offline);
the console's server serves them. A character outside the subsets still shows, in the
machine's font.
"""

from __future__ import annotations

import base64
import io
import shutil
import sys
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

__all__ = [
    "FONTS",
    "FONT_MEDIA_TYPE",
    "MONO",
    "MONO_CODEPOINTS",
    "MONO_FAMILY",
    "SANS",
    "SANS_CODEPOINTS",
    "SANS_FAMILY",
    "WebFont",
    "font_bytes",
    "font_face_css",
    "make_fonts",
]


@dataclass(frozen=True)
class WebFont:
    """One shipped font: its file in ``twopose/fonts/``, its CSS family and weight."""

    file: str
    family: str
    weight: int


#: The CSS family names of the shipped fonts.
SANS_FAMILY = "twopose Sans"
MONO_FAMILY = "twopose Mono"
#: The font stacks the pages name (the generic family last, for characters outside ours).
SANS = f'"{SANS_FAMILY}", sans-serif'
MONO = f'"{MONO_FAMILY}", monospace'

FONTS = (
    WebFont("twopose-sans.woff", SANS_FAMILY, 400),
    WebFont("twopose-sans-bold.woff", SANS_FAMILY, 700),
    WebFont("twopose-mono.woff", MONO_FAMILY, 400),
)
#: Each shipped font's source in matplotlib's fonts (``mpl-data/fonts/ttf``).
SOURCES = {
    "twopose-sans.woff": "DejaVuSans.ttf",
    "twopose-sans-bold.woff": "DejaVuSans-Bold.ttf",
    "twopose-mono.woff": "DejaVuSansMono.ttf",
}
FONT_MEDIA_TYPE = "font/woff"


def _ranges(*spans: tuple[int, int]) -> frozenset[int]:
    return frozenset(c for first, last in spans for c in range(first, last + 1))


#: The characters of the sans fonts: Basic Latin, Latin-1, Latin Extended-A (names),
#: Greek (sigma, mu), punctuation (dashes, quotes, the ellipsis), super- and subscripts,
#: the euro sign, arrows, mathematical operators (<=, +-, the minus sign), geometric
#: shapes (the top view's triangles and circles) and ticks and crosses.
SANS_CODEPOINTS = _ranges(
    (0x20, 0x7E), (0xA0, 0x17F), (0x391, 0x3C9), (0x2010, 0x2027), (0x2030, 0x203A),
    (0x2070, 0x209F), (0x20AC, 0x20AC), (0x2190, 0x21FF), (0x2200, 0x22FF),
    (0x25A0, 0x25FF), (0x2713, 0x2717),
)  # fmt: skip
#: The characters of the monospaced font (file names, numbers, code).
MONO_CODEPOINTS = _ranges(
    (0x20, 0x7E), (0xA0, 0x17F), (0x2010, 0x2027), (0x2190, 0x2193), (0x2212, 0x2212)
)


def font_bytes(file: str) -> bytes:
    """The WOFF file ``file`` of :data:`FONTS`, from the package."""
    if file not in {f.file for f in FONTS}:
        raise KeyError(file)
    return resources.files("twopose").joinpath("fonts", file).read_bytes()


def _data_uri(file: str) -> str:
    return f"data:{FONT_MEDIA_TYPE};base64,{base64.b64encode(font_bytes(file)).decode()}"


def font_face_css(url: Callable[[str], str] | None = None) -> str:
    """The ``@font-face`` rules of :data:`FONTS`, each at ``url(file)``.

    Without ``url``, each font is the ``data:`` URI of itself: a page that is one file.
    """
    where = url or _data_uri
    return "".join(
        f"@font-face{{font-family:'{f.family}';font-weight:{f.weight};font-style:normal;"
        f"src:url('{where(f.file)}') format('woff')}}"
        for f in FONTS
    )


def _subset_woff(source: Path, codepoints: frozenset[int]) -> bytes:
    """``source`` cut to ``codepoints``, without hinting, as WOFF (zlib) bytes."""
    from fontTools import subset
    from fontTools.ttLib import TTFont

    options = subset.Options()
    options.flavor = "woff"
    options.hinting = False
    options.name_IDs = ["*"]  # the copyright and licence notices stay in the font
    options.notdef_outline = True
    options.drop_tables += ["FFTM"]  # FontForge's timestamps: nothing a browser reads
    font = TTFont(source, recalcTimestamp=False)
    subsetter = subset.Subsetter(options)
    subsetter.populate(unicodes=sorted(codepoints))
    subsetter.subset(font)
    font.flavor = "woff"
    out = io.BytesIO()
    font.save(out, reorderTables=True)
    return out.getvalue()


def make_fonts(folder: Path) -> None:
    """Write every font of :data:`FONTS` and their licence into ``folder``.

    Each is its :data:`SOURCES` font (matplotlib's DejaVu) cut to its characters
    (:data:`SANS_CODEPOINTS`, :data:`MONO_CODEPOINTS`), the same bytes every time.
    """
    import matplotlib

    source = Path(matplotlib.__file__).parent / "mpl-data" / "fonts" / "ttf"
    folder.mkdir(parents=True, exist_ok=True)
    for font in FONTS:
        codepoints = MONO_CODEPOINTS if font.family == MONO_FAMILY else SANS_CODEPOINTS
        data = _subset_woff(source / SOURCES[font.file], codepoints)
        (folder / font.file).write_bytes(data)
        print(f"{font.file}: {len(data)} bytes")
    shutil.copyfile(source / "LICENSE_DEJAVU", folder / "LICENSE-DejaVu.txt")


if __name__ == "__main__":
    make_fonts(Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parents[1] / "fonts"))
