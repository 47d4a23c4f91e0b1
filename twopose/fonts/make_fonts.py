"""Write the pages' fonts (the same bytes every time) from the DejaVu fonts matplotlib ships.

    python twopose/fonts/make_fonts.py twopose/fonts/

The report and the operator's console draw their text in these fonts, whatever fonts the
machine has (:mod:`twopose.webfonts`): subsets of DejaVu Sans, DejaVu Sans Bold and DejaVu
Sans Mono (the Latin, Greek, punctuation, arrow, mathematical and shape characters the
pages write, and more), as WOFF files without hinting instructions, so that a glyph is
drawn the same whatever hinting the machine's font settings ask for. Their licence (the
Bitstream Vera licence, DejaVu's changes in the public domain) is ``LICENSE-DejaVu.txt``
beside them; it allows subsets under names without "Bitstream", "Vera" or "Arev".
"""

from __future__ import annotations

import io
import shutil
import sys
from pathlib import Path

import matplotlib
from fontTools import subset
from fontTools.ttLib import TTFont

from twopose.webfonts import FONTS, MONO_CODEPOINTS, SANS_CODEPOINTS

SOURCE = Path(matplotlib.__file__).parent / "mpl-data" / "fonts" / "ttf"
#: Each shipped font's source file in matplotlib's fonts.
SOURCES = {
    "twopose-sans.woff": "DejaVuSans.ttf",
    "twopose-sans-bold.woff": "DejaVuSans-Bold.ttf",
    "twopose-mono.woff": "DejaVuSansMono.ttf",
}


def subset_woff(source: Path, codepoints: frozenset[int]) -> bytes:
    """``source`` cut to ``codepoints``, without hinting, as WOFF (zlib) bytes."""
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


def main(folder: Path) -> None:
    """Write every font of :data:`twopose.webfonts.FONTS` and the licence into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for font in FONTS:
        codepoints = MONO_CODEPOINTS if font.family.endswith("Mono") else SANS_CODEPOINTS
        data = subset_woff(SOURCE / SOURCES[font.file], codepoints)
        (folder / font.file).write_bytes(data)
        print(f"{font.file}: {len(data)} bytes")
    shutil.copyfile(SOURCE / "LICENSE_DEJAVU", folder / "LICENSE-DejaVu.txt")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent))
