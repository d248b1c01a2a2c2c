"""The explorer's page in a real headless Chromium (Debian's), one browser session for all checks.

Without ``/usr/bin/chromium`` (or Playwright) the test fails saying so: ``.ci/run`` installs it.
"""

from __future__ import annotations

import pytest
from conftest import isolated_ok_row

from dpfexplore.bench.explore import (
    DOUBLE_TAP_S,
    launch,
    missing_chromium,
    page_point,
    wait_for_map,
)
from dpfexplore.explore.data import load_dataset
from dpfexplore.explore.server import start_server
from dpfexplore.model.design import load_design

_COUNT = "() => Bokeh.documents[0].get_model_by_name('count').text"


def test_the_page_in_chromium(dataset, frame, tmp_path):
    reason = missing_chromium()
    if reason:
        pytest.fail(f"the explorer's browser test cannot run: {reason}")
    from playwright.sync_api import sync_playwright

    data = load_dataset(dataset)
    running = start_server(data, background=True)
    requests, errors = [], []
    try:
        with sync_playwright() as p:
            context = launch(p, tmp_path / "profile")
            context.on("request", lambda r: requests.append(r.url))
            page = context.pages[0]
            page.on("console", lambda m: m.type == "error" and errors.append(m.text))
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(running.url)
            wait_for_map(page)
            # the map shows every row of the dataset
            total = len(frame)
            assert f"data-count='{total}' data-total='{total}'" in page.evaluate(_COUNT)
            page.get_by_text(f"{total:,} of {total:,} rows shown").wait_for()
            # a click at a known tip shows that design, verified, in the detail pane
            session = running.pages[-1].session
            mm_per_pixel = (session.x_range[1] - session.x_range[0]) / session.width
            i = isolated_ok_row(frame, 4 * mm_per_pixel)
            px, py, _, _ = page_point(page, *data.tip[i])
            page.mouse.click(px, py)
            pick = page.locator(f".pick[data-design-id='{data.design_id[i]}']").first
            pick.wait_for(timeout=30_000)
            assert pick.get_attribute("data-status") == "ok"
            assert float(pick.get_attribute("data-error-mm")) <= 1e-6
            assert "verified: refined with the exact model" in pick.inner_text()
            assert "then re-solved" in pick.inner_text()
            shown = [p.candidate for p in session.last_tap.picks]
            chosen = next(c for c in shown if c.design_id == data.design_id[i])
            assert chosen.state == data.state[i]
            # its TOML downloads and reads back; `states` solves it
            with page.expect_download() as download:
                pick.locator("a.download").click()
            path = tmp_path / "design.toml"
            download.value.save_as(path)
            assert load_design(path).to_dict() == chosen.design.to_dict() | {"name": "design"}
            # a filter changes the count: N = 2 off
            page.wait_for_timeout(DOUBLE_TAP_S * 1e3)
            n2 = int((frame["n_units"] == 2).sum())
            page.get_by_text(f"N = 2 ({n2:,})").click()
            page.get_by_text(f"{total - n2:,} of {total:,} rows shown").wait_for(timeout=30_000)
            assert session.count == total - n2
            context.close()
    finally:
        running.stop()
    assert not errors
    hosts = {url.split("/")[2] for url in requests if url.startswith("http")}
    assert hosts == {f"127.0.0.1:{running.port}"}
    assert not [url for url in requests if not url.startswith(("http://127.0.0.1", "data:"))]
