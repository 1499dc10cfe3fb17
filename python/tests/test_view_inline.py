"""The run page from Python: a Plan and a scenario's TrackResult inline in Jupyter (``_repr_html_``)
and ``brachia.view`` writing the page of a folder or an object."""

import html
import json
import re

import pytest

import brachia


def page_data(page: str) -> dict:
    m = re.search(r'id="brachia-data">(.*?)</script>', page, re.S)
    assert m, "the page embeds its data"
    return json.loads(m.group(1))


def framed_page(frame: str) -> str:
    """The page inside the notebook frame (its srcdoc attribute, unescaped)."""
    m = re.fullmatch(r'<iframe srcdoc="(.*)" sandbox="allow-scripts"[^>]*></iframe>', frame, re.S)
    assert m, frame[:200]
    return html.unescape(m.group(1))


def test_a_plan_shows_its_page_inline(tracking_plan):
    frame = tracking_plan._repr_html_()
    assert frame is not None and "height: 760px" in frame
    page = framed_page(frame)
    assert page == tracking_plan._view_html()
    assert "https://" not in page and "http://" not in page
    d = page_data(page)
    assert d["kind"] == "plan"
    assert abs(d["t"][-1] - tracking_plan.swing_time) <= 5e-6  # the page rounds to 1e-5 s
    # every 1 ms row is there for the tooltips, the drawing keeps one per 10 ms
    assert len(d["full"]["t"]) == len(tracking_plan.t)
    assert len(d["t"]) < len(d["full"]["t"]) / 5
    assert len(page) < 3_000_000


def test_a_scenario_track_shows_its_page_inline_and_a_plain_track_has_none(scenario, tracking_plan, robot):
    res = scenario.track(reference=tracking_plan)
    page = framed_page(res._repr_html_())
    d = page_data(page)
    assert d["kind"] == "track"
    assert len(d["full"]["control_us"]) == len(res.t)
    assert d["ghost"] and d["ee_error"]
    plain = brachia.track(robot, tracking_plan, controller="pd", duration=0.2)
    assert plain._repr_html_() is None
    with pytest.raises(brachia.BrachiaError, match="no page"):
        brachia.view(plain)


def test_view_writes_the_page_of_an_object_or_a_folder(tracking_plan, scenario, tmp_path):
    out = brachia.view(tracking_plan, tmp_path / "plan.html")
    assert out == tmp_path / "plan.html"
    assert out.read_text(encoding="utf-8") == tracking_plan._view_html()
    folder = tmp_path / "run"
    tracking_plan.write(folder)
    page = brachia.view(folder)
    assert page == folder / "view.html" and page_data(page.read_text())["kind"] == "plan"
    with pytest.raises(brachia.BrachiaError, match="not a folder"):
        brachia.view(tmp_path / "plan.html")
