"""analysis.report.html directly: tables escape what they show, align numbers right and words
left, and never widen the page; figures keep their drawn width, alt text and caption."""

from __future__ import annotations

import io
import math

import pandas as pd
from PIL import Image as Pil
from PIL.PngImagePlugin import PngInfo

from analysis.report.html import MIN_FIGURE_SCALE, figure_html, image, page_html, table_html


def test_a_table_escapes_aligns_and_scrolls_in_its_own_box() -> None:
    df = pd.DataFrame(
        {
            "session": ["<b>a</b>.mcap", "x & y"],
            "RMSE (in)": ["0.40", "-"],
            "bias x ± 95%": ["+0.01 ± 0.03", "-0.20 ± 0.10"],
            "share": ["92%", "100%"],
            "value": [1.0 / 3.0, math.nan],
            "tiny": [1e-12, 2.5e6],
        }
    )
    html = table_html(df)
    assert html.startswith("<div class='wide'><div class='scroll'><table class='t'>")
    assert "&lt;b&gt;a&lt;/b&gt;.mcap" in html
    assert "<b>" not in html
    assert "x &amp; y" in html
    # words left; numbers (text that reads as numbers too) right
    assert "<th class='l'>session</th>" in html
    for number in ("RMSE (in)", "bias x ± 95%", "share", "value", "tiny"):
        assert f"<th>{number}</th>" in html, number
    assert "<td>0.3333</td>" in html  # four significant digits
    assert "<td></td>" in html  # NaN shows empty
    assert "<td>0</td>" in html  # floating-point noise reads 0
    assert "<td>2.5e+06</td>" in html
    text = table_html(df, text=True)
    assert "class='t text'" in text
    assert "<th>" not in text  # a table of sentences aligns everything left


def _png(width: int, description: str) -> bytes:
    info = PngInfo()
    info.add_text("Description", description)
    buffer = io.BytesIO()
    Pil.new("RGB", (width, 10)).save(buffer, format="PNG", pnginfo=info)
    return buffer.getvalue()


def test_a_figure_keeps_its_width_description_and_caption() -> None:
    img = image(_png(528, 'errors by "trial" <1>'))
    assert img.width == 528
    assert img.description == 'errors by "trial" <1>'
    html = figure_html("error_by_trial", img, caption="Each trial's error.")
    assert 'alt="errors by &quot;trial&quot; &lt;1&gt;"' in html
    assert "data-name='error_by_trial'" in html
    assert f"min-width:{math.ceil(MIN_FIGURE_SCALE * 528)}px" in html
    assert html.endswith("<figcaption>Each trial's error.</figcaption></figure>")
    assert figure_html("missing", None) == ""
    unnamed = figure_html("scatter", image(_png(10, "")))
    assert 'alt="scatter"' in unnamed


def test_the_page_escapes_its_title_and_holds_its_body() -> None:
    page = page_html("run <1>", ["<p>body</p>"])
    assert page.startswith("<!DOCTYPE html>") or page.lower().startswith("<!doctype html>")
    assert "<title>run &lt;1&gt;</title>" in page
    assert "<p>body</p>" in page
