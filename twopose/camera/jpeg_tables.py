"""A JPEG's Huffman tables: the standard ones inserted where a webcam's MJPG frame has none.

Many UVC webcams send MJPG frames without a DHT segment: the frames of Motion-JPEG leave the
Huffman tables out, and a decoder is to use the example tables of the JPEG standard (ITU-T
T.81, Annex K.3; the AVI and UVC MJPG formats say so). libjpeg-turbo (OpenCV's
``imdecode``, Pillow, Chromium, Firefox) falls back to those tables by itself; other decoders
do not (Go's ``image/jpeg``, Java's ImageIO, several JavaScript decoders, strict validators),
and such a frame is no interchange-format JPEG. So a session stores each JPEG frame with
its tables: :func:`with_huffman_tables` inserts a DHT segment holding the standard tables a
frame lacks, just before its first scan (where libjpeg writes its tables), and changes no
other byte. That is what ffmpeg's ``mjpeg2jpeg`` filter does; it is lossless (the
entropy-coded data is untouched, so the decoded pixels are the same: the tables are those
the decoder would have assumed) and costs 420 bytes a frame.
"""

from __future__ import annotations

__all__ = ["STANDARD_TABLES", "huffman_tables", "with_huffman_tables"]

#: The standard Huffman tables (T.81 Annex K.3), by (class, id): class 0 DC, 1 AC; id 0
#: luminance, 1 chrominance; each the 16 code counts per length and the values, as a DHT
#: segment stores them.
STANDARD_TABLES: dict[tuple[int, int], tuple[bytes, bytes]] = {
    (0, 0): (
        bytes.fromhex("00010501010101010100000000000000"),
        bytes.fromhex("000102030405060708090a0b"),
    ),
    (0, 1): (
        bytes.fromhex("00030101010101010101010000000000"),
        bytes.fromhex("000102030405060708090a0b"),
    ),
    (1, 0): (
        bytes.fromhex("0002010303020403050504040000017d"),
        bytes.fromhex(
            "01020300041105122131410613516107227114328191a1082342b1c11552d1f02433627282090a16"
            "1718191a25262728292a3435363738393a434445464748494a535455565758595a63646566676869"
            "6a737475767778797a838485868788898a92939495969798999aa2a3a4a5a6a7a8a9aab2b3b4b5b6"
            "b7b8b9bac2c3c4c5c6c7c8c9cad2d3d4d5d6d7d8d9dae1e2e3e4e5e6e7e8e9eaf1f2f3f4f5f6f7f8"
            "f9fa"
        ),
    ),
    (1, 1): (
        bytes.fromhex("00020102040403040705040400010277"),
        bytes.fromhex(
            "000102031104052131061241510761711322328108144291a1b1c109233352f0156272d10a162434"
            "e125f11718191a262728292a35363738393a434445464748494a535455565758595a636465666768"
            "696a737475767778797a82838485868788898a92939495969798999aa2a3a4a5a6a7a8a9aab2b3b4"
            "b5b6b7b8b9bac2c3c4c5c6c7c8c9cad2d3d4d5d6d7d8d9dae2e3e4e5e6e7e8e9eaf2f3f4f5f6f7f8"
            "f9fa"
        ),
    ),
}

_SOI, _SOS, _DHT, _EOI = 0xD8, 0xDA, 0xC4, 0xD9
#: Frame headers of the Huffman-coded processes: baseline, extended and progressive DCT
#: (the others are arithmetic-coded or lossless: their tables are not these).
_HUFFMAN_FRAMES = frozenset((0xC0, 0xC1, 0xC2))
#: Markers without a length (a lone fill or restart marker; TEM).
_STANDALONE = frozenset((0x01, *range(0xD0, 0xD8)))


def huffman_tables(data: bytes) -> tuple[set[tuple[int, int]], int, bool] | None:
    """What a JPEG's segments before its first scan say of its Huffman tables.

    The tables it defines, by (class, id); where its first scan (its SOS marker) begins;
    and whether its frame is Huffman-coded (SOF0-2). None when ``data`` is not a JPEG
    whose segments lead to a scan (no SOI, a segment cut short, no SOS): such bytes are
    left as they are.
    """
    if data[:2] != b"\xff\xd8":
        return None
    defined: set[tuple[int, int]] = set()
    huffman, at = False, 2
    while at + 4 <= len(data):
        if data[at] != 0xFF:
            return None
        marker = data[at + 1]
        if marker == 0xFF:  # fill bytes before a marker
            at += 1
            continue
        if marker in _STANDALONE:
            at += 2
            continue
        if marker in (_SOI, _EOI):
            return None
        if marker == _SOS:
            return defined, at, huffman
        end = at + 2 + int.from_bytes(data[at + 2 : at + 4], "big")
        if end > len(data) or end < at + 4:
            return None
        if marker == _DHT:
            defined |= _tables_in(data[at + 4 : end])
        huffman |= marker in _HUFFMAN_FRAMES
        at = end
    return None


def _tables_in(segment: bytes) -> set[tuple[int, int]]:
    """The (class, id) of each table a DHT segment's body defines."""
    found, k = set(), 0
    while k + 17 <= len(segment):
        found.add((segment[k] >> 4, segment[k] & 0x0F))
        k += 17 + sum(segment[k + 1 : k + 17])
    return found


def with_huffman_tables(data: bytes) -> bytes:
    """``data`` with the standard Huffman tables it lacks, inserted (the module docstring).

    The tables of :data:`STANDARD_TABLES` it does not define, in one DHT segment before its
    first scan; ``data`` itself when it defines them all, is not Huffman-coded, or is not a
    JPEG that can be walked to its scan (nothing is guessed).
    """
    found = huffman_tables(data)
    if found is None:
        return data
    defined, scan, huffman = found
    missing = [key for key in STANDARD_TABLES if key not in defined]
    if not huffman or not missing:
        return data
    body = b"".join(
        bytes([c << 4 | i]) + STANDARD_TABLES[(c, i)][0] + STANDARD_TABLES[(c, i)][1]
        for c, i in missing
    )
    segment = b"\xff\xc4" + (len(body) + 2).to_bytes(2, "big") + body
    return data[:scan] + segment + data[scan:]
