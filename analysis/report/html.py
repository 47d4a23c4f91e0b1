"""Self-contained HTML pages (the report, the comparison) that read at 1280 px and at
390 px (a phone): the text reflows; a table or a figure wider than the page scrolls inside
its own box, and a cue says so (the line above it, a shade on its right edge) for as long
as there is more to the right; a figure keeps at least :data:`MIN_FIGURE_SCALE` of its
drawn width, so that its text stays legible, and scrolls beyond.
"""

from __future__ import annotations

import base64
import html
import io
import math
import re
from dataclasses import dataclass

import pandas as pd

from twopose.display import fonts as webfonts

__all__ = [
    "MIN_FIGURE_SCALE",
    "Image",
    "chart_html",
    "chart_scripts",
    "figure_html",
    "figure_row",
    "image",
    "page_html",
    "table_html",
    "wide",
]

#: The smallest share of its drawn width a figure is shown at: a 4.8 in figure at 110 dpi
#: (528 px) fits a 390 px phone at 0.68, its 9 pt labels 8 px high or more.
MIN_FIGURE_SCALE = 0.65


def _rounded(value: float) -> str:
    """Four significant digits; floating-point noise (|v| < 1e-9) reads 0."""
    return "0" if abs(value) < 1e-9 else f"{value:.4g}"


def wide(inner: str) -> str:
    """``inner`` in a box that scrolls sideways when it is wider than the page, with a cue
    (the page's script marks the box ``overflows``)."""
    return f"<div class='wide'><div class='scroll'>{inner}</div></div>"


def _cell(value: object) -> str:
    """A cell's text: floats to four significant digits, missing values empty."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if isinstance(value, float):
        return _rounded(value)
    return html.escape(str(value))


def _numeric(column: pd.Series) -> bool:
    """Whether a column reads as numbers (aligned right): numbers, or text that is numbers
    (``0.40``, ``92%``, ``+0.00 ± 0.03``) where it is not empty."""
    if pd.api.types.is_numeric_dtype(column) and not pd.api.types.is_bool_dtype(column):
        return True
    cells = [str(v) for v in column if str(v) not in ("", "-", "nan", "None")]
    return bool(cells) and all(_NUMBER.fullmatch(c) for c in cells)


_NUMBER = re.compile(r"[-+]?\d[\d.]*(e[-+]?\d+)?%?( (±|to) [-+]?\d[\d.]*)?")


def table_html(df: pd.DataFrame, *, text: bool = False) -> str:
    """A table that scrolls inside its own box: a wide one never widens the page. Numbers
    align right and never wrap, words align left; a table of sentences (``text``) aligns
    left and wraps."""
    classes = "t text" if text else "t"
    numeric = [not text and _numeric(df[c]) for c in df.columns]
    align = ["" if n else " class='l'" for n in numeric]
    head = "".join(
        f"<th{a}>{html.escape(str(c))}</th>" for c, a in zip(df.columns, align, strict=True)
    )
    rows = "".join(
        "<tr>"
        + "".join(f"<td{a}>{_cell(v)}</td>" for v, a in zip(row, align, strict=True))
        + "</tr>\n"
        for row in df.itertuples(index=False, name=None)
    )
    body = f"<table class='{classes}'><thead><tr>{head}</tr></thead><tbody>\n{rows}</tbody></table>"
    return wide(body)


@dataclass(frozen=True, kw_only=True)
class Image:
    """A PNG for the page: its data, its width in pixels and its description (alt text)."""

    base64: str
    width: int
    description: str


def image(png: bytes) -> Image:
    """A PNG with its width (the header's) and the ``Description`` it was saved with."""
    from PIL import Image as Pil

    with Pil.open(io.BytesIO(png)) as picture:
        width = picture.width
        text = getattr(picture, "text", {}) or {}
    return Image(
        base64=base64.b64encode(png).decode(),
        width=width,
        description=str(text.get("Description", "")),
    )


def figure_html(name: str, img: Image | None, caption: str = "") -> str:
    """A figure at its drawn width, never under :data:`MIN_FIGURE_SCALE` of it (a
    narrower page scrolls it, with the cue), and its caption (an HTML fragment)."""
    if img is None:
        return ""
    alt = html.escape(img.description or name, quote=True)
    least = math.ceil(MIN_FIGURE_SCALE * img.width)
    tag = (
        f"<img alt=\"{alt}\" data-name='{html.escape(name)}' width='{img.width}' "
        f"style='min-width:{least}px' src='data:image/png;base64,{img.base64}'>"
    )
    text = f"<figcaption>{caption}</figcaption>" if caption else ""
    return f"<figure style='width:{img.width}px'>{wide(tag)}{text}</figure>"


def chart_html(name: str, spec: dict[str, object] | None, caption: str = "") -> str:
    """A chart the page's script draws from ``spec`` (a Vega-Lite spec with its data), in
    a box that scrolls sideways when wider than the page, and its caption."""
    if spec is None:
        return ""
    from twopose.values import jsonsafe

    # "</" never closes the script element early; JSON reads "<\/" as "</".
    data = jsonsafe.dumps(spec).replace("</", "<\\/")
    text = f"<figcaption>{caption}</figcaption>" if caption else ""
    box = wide(f"<div class='chart' data-chart='{html.escape(name, quote=True)}'></div>")
    return (
        f"<figure class='chart-figure'>{box}"
        f"<script type='application/json' class='chart-spec'>{data}</script>{text}</figure>"
    )


#: The scripts that draw the charts, carried in the package (analysis/report/js/VERSIONS).
CHART_SCRIPTS = ("vega.min.js", "vega-lite.min.js", "vega-embed.min.js")

# Draws every chart from the spec beside it, in the page's font once it is loaded (Vega
# measures its labels with it): on a narrow page (a phone) one column, as wide
# as the page, the legends below and long titles wrapped onto lines (about 8 px a character
# of the 13 px bold title; cut only beyond a line's width); each view kept
# by name (window.twoposeViews) for the tests and the console of a curious reader.
_CHART_SCRIPT = (
    "window.twoposeViews={};function wrapTitle(u,n){var t=u.title;"
    "if(typeof t!=='string'||t.length<=n)return;var lines=[''];"
    "t.split(' ').forEach(function(x){var l=lines[lines.length-1];"
    "if(l&&l.length+x.length+1>n)lines.push(x);else lines[lines.length-1]=l?l+' '+x:x});"
    "u.title={text:lines}}function drawCharts(){"
    "document.querySelectorAll('div.chart').forEach(function(el){"
    "var spec=JSON.parse(el.parentElement.parentElement.nextElementSibling.textContent);"
    f"spec.config=Object.assign({{font:'{webfonts.SANS_FAMILY}'}},spec.config);"
    "if(innerWidth<700){if(spec.columns)spec.columns=1;var c=spec.config||{},w=innerWidth-135;"
    "(spec.concat||[]).forEach(function(u){if(u.width>w)u.width=w;"
    "wrapTitle(u,Math.floor((Math.min(u.width||w,w)+60)/8))});"
    "spec.config=Object.assign({},c,{legend:Object.assign({},c.legend,{orient:'bottom'}),"
    "title:Object.assign({},c.title,{limit:w+60})})}"
    "vegaEmbed(el,spec,{actions:false,renderer:'svg',mode:'vega-lite'}).then(function(r){"
    "window.twoposeViews[el.dataset.chart]=r.view;cues()}).catch(function(e){"
    "el.textContent='This chart could not be drawn: '+e.message})})}"
    "addEventListener('DOMContentLoaded',function(){var f=document.fonts;"
    "if(!f||!f.load)return drawCharts();"
    "Promise.all(['12px','bold 12px'].map(function(s){"
    f"return f.load(s+\" '{webfonts.SANS_FAMILY}'\")}}))"
    ".then(drawCharts,drawCharts)});"
)


def chart_scripts() -> list[str]:
    """The chart scripts, inline (the page opens offline, from a file), then ours."""
    from importlib.resources import files

    folder = files("analysis.report") / "js"
    return [*(folder.joinpath(n).read_text("utf-8") for n in CHART_SCRIPTS), _CHART_SCRIPT]


def figure_row(figures: list[str]) -> str:
    """Figures side by side where the page is wide enough, one under the other where not."""
    return f"<div class='figs'>{''.join(figures)}</div>"


_STYLE = (
    f"body{{font-family:{webfonts.SANS};max-width:1200px;margin:2em auto;padding:0 1em;color:#222;"
    "line-height:1.4}"
    f"code,pre,kbd,samp{{font-family:{webfonts.MONO};font-size:0.85em}}"
    "h1{font-size:1.8em}h2{border-bottom:1px solid #aaa;margin-top:1.6em}"
    "h1,h2,h3,p,li,figcaption{overflow-wrap:anywhere}p{max-width:62em}"
    ".wide{position:relative;margin:0.8em 0}"
    ".scroll{overflow-x:auto;max-width:100%}"
    "img{max-width:100%;height:auto;display:block}"
    ".wide.overflows::before{content:'\\2194  wider than the page: scroll sideways';"
    "display:block;height:18px;line-height:18px;font-size:12px;color:#555}"
    ".wide.overflows::after{content:'';position:absolute;top:18px;right:0;bottom:0;"
    "width:28px;pointer-events:none;"
    "background:linear-gradient(to right,rgba(255,255,255,0),rgba(0,0,0,0.22))}"
    ".wide.overflows.at-end::after{display:none}"
    "table.t{border-collapse:collapse;font-size:12px}"
    "table.t td,table.t th{padding:2px 8px;border-bottom:1px solid #ddd;text-align:right;"
    "white-space:nowrap}table.t th{white-space:normal;vertical-align:bottom;min-width:3em}"
    "table.t .l{text-align:left}"
    "table.t:not(.text) td:first-child,table.t:not(.text) th:first-child"
    "{position:sticky;left:0;background:#fff}"
    "table.text td,table.text th{text-align:left;white-space:normal;min-width:9em;"
    "max-width:30em}"
    ".chart-figure{width:auto}.chart{min-height:60px}"
    "#vg-tooltip-element{font-size:12px;font-family:inherit}"
    "figure{margin:1.2em 0;max-width:100%}figcaption{font-size:13px;color:#444}"
    ".figs{display:flex;flex-wrap:wrap;column-gap:2.5em;align-items:flex-start}"
    "nav a{white-space:nowrap}.err{color:#a00}.verdict{font-weight:bold;margin:0.4em 0}"
    "@media (max-width:600px){table.text td,table.text th{min-width:0;padding:2px 4px}}"
)

# Marks each scroll box that is wider than its page (the cue shows) and whether it is
# scrolled to its end (the shade goes).
_SCRIPT = (
    "function cue(b){var w=b.parentElement;"
    "w.classList.toggle('overflows',b.scrollWidth>b.clientWidth+1);"
    "w.classList.toggle('at-end',b.scrollLeft+b.clientWidth>=b.scrollWidth-1)}"
    "function cues(){document.querySelectorAll('.scroll').forEach(cue)}"
    "addEventListener('load',cues);addEventListener('resize',cues);"
    "document.addEventListener('scroll',function(e){var b=e.target;"
    "if(b.classList&&b.classList.contains('scroll'))cue(b)},true);"
)


def page_html(title: str, body: list[str], scripts: tuple[str, ...] | list[str] = ()) -> str:
    """A self-contained page: our style, no horizontal overflow, ``body``'s parts and
    ``scripts`` inline (:func:`chart_scripts` for charts)."""
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        "<meta name='viewport' content='width=device-width, initial-scale=1'>",
        f"<title>{html.escape(title)}</title><style>{webfonts.font_face_css()}{_STYLE}</style>",
        f"<script>{_SCRIPT}</script>",
        *(f"<script>{s}</script>" for s in scripts),
        "</head><body>",
        *body,
        "</body></html>",
    ]
    return "\n".join(p for p in parts if p)
