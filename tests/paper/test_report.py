"""The HTML report (encal.paper.report): one self-contained file with every table and figure."""

import base64
import re
from html.parser import HTMLParser

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

from encal.paper.report import FIGURES, build_report, render_figures, write_report  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def result(tiny_demo):
    """The smallest demo's result (conftest's ``tiny_demo``, shared with test_demo.py)."""
    return tiny_demo[1]


@pytest.fixture(scope="module")
def figures(result):
    return render_figures(result, workers=0)


@pytest.fixture(scope="module")
def page(result, figures):
    return build_report(result, figures)


class _Tags(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags, self.attributes, self.open = [], [], []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.attributes += [(tag, name, value) for name, value in attrs]
        if tag not in ("meta", "img", "br"):
            self.open.append(tag)

    def handle_endtag(self, tag):
        assert self.open and self.open[-1] == tag, f"</{tag}> closes <{self.open[-1] if self.open else None}>"
        self.open.pop()


def test_every_figure_is_rendered_as_png(figures):
    assert list(figures) == list(FIGURES)
    assert all(png.startswith(PNG_MAGIC) for png in figures.values())


def test_report_is_well_formed_and_self_contained(page, figures):
    tags = _Tags()
    tags.feed(page)
    assert tags.open == []
    assert "script" not in tags.tags and "link" not in tags.tags
    sources = [value for tag, name, value in tags.attributes if name in ("src", "href")]
    assert len(sources) == len(figures)
    for source in sources:
        assert source.startswith("data:image/png;base64,")
        assert base64.b64decode(source.split(",", 1)[1]).startswith(PNG_MAGIC)
    assert not re.search(r"(?:https?:)?//[\w.-]+\.\w+/", page.replace("http://www.w3.org", ""))
    assert "<style>" in page and page.startswith("<!DOCTYPE html>")


def test_report_holds_every_table(result, page):
    for table in result.tables.values():
        assert table.title.replace("'", "&#x27;") in page
    assert page.count("<table>") == len(result.tables)


def test_summary_states_each_encoders_accuracy_before_and_after(result, page):
    for name, encoder in result.encoders.items():
        before = encoder.comparison.entry("before").stats
        after = encoder.saved.stats
        assert f"<b>{name}</b>: before compensation its readings are off by up to {before.max_abs:.2f}" in page
        assert f"(RMS {after.rms:.3f})" in page
        assert f"{name}.json" in page


def test_write_report_writes_utf8(result, figures, tmp_path):
    path = write_report(result, tmp_path / "report.html", figures)
    text = path.read_text(encoding="utf-8")
    assert text == build_report(result, figures)
    assert "θ" in text  # figure captions keep their symbols


def test_no_python_representation_reaches_the_page(page):
    assert not re.search(r"DemoSettings\(|np\.float|array\(|<encal|object at 0x|\bNone\b|\bnan\b|dtype=", page)
    assert "Demo settings: 2 encoders; sweep N = " in page


def test_before_and_after_share_the_axes_of_one_panel_per_encoder(result):
    from encal.paper.report import _before_after

    fig = _before_after(result)
    panels = [ax for ax in fig.axes if ax.get_visible()]
    assert len(panels) == len(result.encoders)
    for ax, encoder in zip(panels, result.encoders.values()):
        labels = [line.get_label() for line in ax.get_lines()]
        assert any(label.startswith("before (RMS") for label in labels)
        assert any(label.startswith("after (RMS") for label in labels)
        assert f"(RMS {encoder.saved.stats.rms:.3g} arcmin)" in " ".join(labels)
