"""Pieces of encal's self-contained HTML reports: the style sheet, figures as data URIs, tables, text.

Every value put into a page goes through :func:`html.escape`; numbers are formatted by the caller, so
no Python representation reaches the page.
"""

import base64
import html

__all__ = ["CSS", "figure", "paragraph", "table", "page"]

CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
       max-width: 1180px; margin: 2em auto; padding: 0 1.5em; color: #222; line-height: 1.45; }
h1 { font-size: 1.7em; margin-bottom: 0.2em; }
h2 { font-size: 1.3em; margin-top: 2em; border-bottom: 1px solid #ddd; padding-bottom: 0.2em; }
.meta { color: #666; font-size: 0.9em; }
table { border-collapse: collapse; margin: 1em 0 0.3em; font-size: 0.86em; }
caption { text-align: left; font-weight: 600; padding-bottom: 0.4em; }
th, td { padding: 0.25em 0.6em; border-bottom: 1px solid #e4e4e4; }
th { background: #f4f4f4; text-align: center; font-weight: 600; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
td.text { text-align: left; }
p.note { font-size: 0.82em; color: #555; margin: 0.2em 0; max-width: 60em; }
figure { margin: 1.2em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: 0.88em; color: #444; max-width: 60em; }
ul.summary li { margin-bottom: 0.5em; }
p.verdict { font-size: 1.08em; background: #f3f7fb; border-left: 4px solid #1f77b4; padding: 0.6em 0.9em;
            max-width: 60em; }
.scroll { overflow-x: auto; }
"""


def figure(name, png, caption):
    """A ``<figure>`` with the PNG embedded as a data URI; ``data-figure`` names it for checks."""
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure><img data-figure="{html.escape(name)}" alt="{html.escape(caption)}" '
            f'src="data:image/png;base64,{data}"><figcaption>{html.escape(caption)}</figcaption></figure>')


def paragraph(text, css_class=None):
    """One paragraph of plain text."""
    attribute = f' class="{css_class}"' if css_class else ""
    return f"<p{attribute}>{html.escape(text)}</p>"


def table(header, rows, caption=None, numeric=None):
    """An HTML table of already formatted cells.

    Parameters
    ----------
    header : sequence of str
    rows : sequence of sequence of str
    caption : str, optional
    numeric : sequence of bool, optional
        Per column, right-aligned as a number (default: every column but the first).
    """
    numeric = numeric or [index > 0 for index in range(len(header))]
    head = "".join(f"<th>{html.escape(cell)}</th>" for cell in header)
    body = "".join(
        "<tr>" + "".join(f'<td class="{"num" if numeric[i] else "text"}">{html.escape(cell)}</td>'
                         for i, cell in enumerate(row)) + "</tr>" for row in rows)
    title = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f'<div class="scroll"><table>{title}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table></div>'


#: Counts the figures the browser decoded and writes the count into ``<body data-figures-loaded>``, and the
#: page's laid-out width into ``data-page-width``, so a headless browser's dumped DOM shows whether every
#: figure displays and whether anything sticks out past the window.
_FIGURE_CHECK = """<script>
window.addEventListener("load", function () {
  var images = document.querySelectorAll("img[data-figure]"), loaded = 0;
  images.forEach(function (img) { if (img.complete && img.naturalWidth > 0) { loaded += 1; } });
  document.body.setAttribute("data-figures-loaded", String(loaded));
  document.body.setAttribute("data-figures", String(images.length));
  document.body.setAttribute("data-page-width", String(document.documentElement.scrollWidth));
});
</script>"""


def page(title, parts):
    """A whole HTML document: inline style, the parts in order, and the figure check."""
    head = ['<!DOCTYPE html>', '<html lang="en"><head><meta charset="utf-8">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>{html.escape(title)}</title>", f"<style>{CSS}</style>", _FIGURE_CHECK, "</head><body>"]
    return "\n".join([*head, *(part for part in parts if part), "</body></html>"])
