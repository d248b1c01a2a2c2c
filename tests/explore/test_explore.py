"""The explorer: its data, map image and callbacks in Python, its refusals, and its page in a
real headless Chromium (Debian's; one browser session for all browser checks).

Without ``/usr/bin/chromium`` (or Playwright) the browser test fails saying so: ``.ci/run``
installs it.
"""

from __future__ import annotations

import json
import re
import shutil
import signal
import socket
import subprocess
import sys
import urllib.request

import numpy as np
import pytest
from sweep_helpers import make_job

from dpfexplore.bench.explore import (
    DOUBLE_TAP_S,
    launch,
    missing_chromium,
    page_point,
    wait_for_map,
)
from dpfexplore.cli import main
from dpfexplore.explore.data import Filters, load_dataset, parse_state_pattern
from dpfexplore.explore.designs import DesignFinder
from dpfexplore.explore.raster import CATEGORY_COLOURS, rasterize
from dpfexplore.explore.server import start_server
from dpfexplore.explore.session import ExploreSession
from dpfexplore.model.design import load_design
from dpfexplore.sweep.driver import run_sweep
from dpfexplore.sweep.storage.store import read_results

#: Designs per N; every state: 100 * (4 + 8 + 16) = 2800 rows.
SAMPLES = 100


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    """A complete sweep directory of the solver's rows (stiffness, min eig, every state)."""
    out = tmp_path_factory.mktemp("explore") / "small"
    spec = make_job(
        **{
            "space.n_units": [2, 3, 4],
            "job.samples_per_n": SAMPLES,
            "compute.states": "all",
            "compute.min_eig": True,
        }
    )
    run_sweep(spec, out)
    return out


@pytest.fixture(scope="module")
def frame(dataset):
    """The dataset as pandas reads it through the store (the independent reference)."""
    return read_results(dataset)


def isolated_ok_row(frame, tip_scale: float) -> int:
    """A row with status ok whose tip is farther than ``tip_scale`` mm from every other tip."""
    tips = frame[["tip_x", "tip_y"]].to_numpy(float)
    finite = np.all(np.isfinite(tips), axis=1)
    best, best_gap = -1, 0.0
    for i in np.flatnonzero((frame["status"].to_numpy() == 0) & finite):
        d = np.hypot(*(tips[finite] - tips[i]).T)
        gap = np.partition(d, 1)[1]
        if gap > best_gap and 15 < tips[i, 0] < 55:
            best, best_gap = int(i), float(gap)
    assert best_gap > tip_scale, f"no tip isolated by {tip_scale} mm"
    return best


@pytest.fixture(scope="module")
def data(dataset):
    return load_dataset(dataset)


@pytest.fixture(scope="module")
def finder(data):
    return DesignFinder(data)


def test_the_dataset_is_read_whole_and_filters_count_its_rows(data, frame):
    assert len(data) == len(frame) == data.info.rows_committed == 100 * (4 + 8 + 16)
    np.testing.assert_array_equal(data.tip, frame[["tip_x", "tip_y"]].to_numpy(float))
    assert {"stiffness", "min_eig", "curvature"} <= set(data.columns)
    assert data.materials_present == ("cheetah-95a",)
    n = frame["n_units"].to_numpy()
    bits = frame["requested_bits"].astype(str).to_numpy()
    stiff = frame["stiffness"].to_numpy(float)
    assert data.mask(Filters(n_units=(2,))).sum() == np.sum(n == 2) == 400
    assert data.mask(Filters(state="1*")).sum() == np.sum(np.isin(bits, ["10", "11"])) == 200
    assert data.mask(Filters(state="*1*1")).sum() == 100 * 4
    assert data.mask(Filters(statuses=("ok",))).sum() == np.sum(frame["status"] == 0)
    low, high = np.nanpercentile(stiff, [25, 75])
    kept = data.mask(Filters(ranges={"stiffness": (low, high)}, material="cheetah-95a"))
    assert kept.sum() == np.sum((stiff >= low) & (stiff <= high))
    assert data.mask(Filters(material="ninjaflex-85a")).sum() == 0
    with pytest.raises(ValueError, match="state pattern '12'"):
        parse_state_pattern("12")
    with pytest.raises(ValueError, match="column 'nope'"):
        data.mask(Filters(ranges={"nope": (0, 1)}))


def test_the_map_bins_each_tip_into_its_pixel_with_its_colour():
    tip = np.array([[0.5, 0.5], [0.5, 0.5], [3.5, 1.5], [9.0, 9.0]])
    # 4 x 2 pixels of 1 mm over x 0..4, y 0..2: rows 0, 1 in pixel (0, 0), row 2 in (3, 1)
    raster = rasterize(tip, (0.0, 4.0), (0.0, 2.0), 4, 2, categories=np.array([0, 1, 1, 0]))
    rgba = raster.image.view(np.uint8).reshape(2, 4, 4)
    assert raster.rows == 3  # the fourth tip lies outside
    assert np.count_nonzero(rgba[..., 3]) == 2
    assert rgba[0, 0, 3] == 255 and rgba[1, 3, 3] == round(
        255 * (0.4 + 0.6 * np.log(2) / np.log(3))
    )
    np.testing.assert_array_equal(rgba[1, 3, :3], CATEGORY_COLOURS[1])
    np.testing.assert_array_equal(rgba[0, 0, :3], np.round(CATEGORY_COLOURS[:2].mean(axis=0)))
    by_value = rasterize(tip, (0.0, 4.0), (0.0, 2.0), 4, 2, values=np.array([0.0, 1.0, 1.0, 5.0]),
                         limits=(0.0, 1.0))  # fmt: skip
    from matplotlib import colormaps

    mid, top = (np.round(np.array(colormaps["viridis"](v)[:3]) * 255) for v in (128 / 255, 1.0))
    rgba = by_value.image.view(np.uint8).reshape(2, 4, 4)
    np.testing.assert_array_equal(rgba[0, 0, :3], mid)  # mean 0.5 of the two rows there
    np.testing.assert_array_equal(rgba[1, 3, :3], top)


def test_a_tap_at_a_known_tip_selects_that_design_verified(data, finder, frame, tmp_path, capsys):
    from bokeh.document import Document
    from bokeh.events import Tap

    from dpfexplore.explore.page import build_document

    session = ExploreSession(data, finder)
    page = build_document(Document(), session)
    assert "2,800</b> of 2,800 rows" in page.count.text
    i = isolated_ok_row(frame, 0.05)
    x, y = data.tip[i]
    result = page.on_tap(Tap(page.map, x=float(x), y=float(y)))
    best = result.picks[0].candidate
    assert (best.design_id, best.state) == (data.design_id[i], data.state[i])
    assert best.status == "ok" and best.error_mm <= 1e-6
    assert abs(best.stiffness - frame["stiffness"].iloc[i]) <= 1e-9 * abs(best.stiffness)
    assert result.picks[0].states[0].requested == data.state[i]
    assert f"data-design-id='{best.design_id}'" in page.details.text
    assert page.marks.data == {"x": [x], "y": [y]}
    # the design file reads back and `states` solves it into the same state and tip
    path = tmp_path / "design.toml"
    path.write_text(result.picks[0].toml)
    assert load_design(path).to_dict() == best.design.to_dict() | {"name": "design"}
    capsys.readouterr()
    assert main(["states", str(path), "--json"]) == 0
    solved = {s["state"]: s for s in json.loads(capsys.readouterr().out)["states"]}
    np.testing.assert_allclose(solved[best.state]["tip"], [x, y], rtol=0, atol=1e-9)


def test_the_filter_widgets_change_the_count_and_the_map(data, finder):
    from bokeh.document import Document

    from dpfexplore.explore.page import build_document

    session = ExploreSession(data, finder)
    page = build_document(Document(), session)
    before = page.raster.data["image"][0].copy()
    page.n_units.active = [0]  # only N = 2
    assert session.count == 400 and "<b>400</b> of 2,800" in page.count.text
    assert not np.array_equal(page.raster.data["image"][0], before)
    page.state.value = "11"
    assert session.count == 100
    result = session.tap(*data.tip[np.flatnonzero(data.n_units == 4)[0]])
    assert all(p.candidate.design.n_units == 2 and p.candidate.state == "11" for p in result.picks)
    page.state.value = "2"
    assert "state pattern &#x27;2&#x27;" in page.message.text and session.count == 100
    page.colour.value = "stiffness"
    assert "stiffness: mean per pixel" in page.legend.text


def _one_line(capsys, code, expected, *needles):
    err = capsys.readouterr().err.strip()
    assert code == expected, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for needle in needles:
        assert needle in err, err


def test_bad_datasets_and_ports_are_refused_in_one_line(dataset, tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    _one_line(capsys, main(["explore", str(empty), "--no-browser"]), 2, str(empty))
    _one_line(capsys, main(["explore", str(tmp_path / "none"), "--no-browser"]), 2, "none")
    tampered = tmp_path / "tampered"
    shutil.copytree(dataset, tampered)
    chunk = sorted(tampered.glob("N03/part-*.parquet"))[0]
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF  # same size, one byte changed
    chunk.write_bytes(bytes(raw))
    listing = sorted(p.name for p in tampered.iterdir())
    _one_line(capsys, main(["explore", str(tampered), "--no-browser"]), 2, chunk.name)
    assert sorted(p.name for p in tampered.iterdir()) == listing  # nothing written
    incomplete = tmp_path / "incomplete"
    shutil.copytree(dataset, incomplete)
    manifest = json.loads((incomplete / "_manifest.json").read_text())
    manifest["complete"] = False
    (incomplete / "_manifest.json").write_text(json.dumps(manifest))
    _one_line(capsys, main(["explore", str(incomplete), "--no-browser"]), 2, "incomplete")
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        _one_line(
            capsys,
            main(["explore", str(dataset), "--port", str(port), "--no-browser"]),
            2,
            f"port {port}",
        )


def test_a_dataset_without_tip_columns_is_refused(tmp_path, capsys):
    from sweep_helpers import UnitConstantsEvaluator, make_job

    from dpfexplore.sweep.driver import run_sweep

    out = tmp_path / "units"
    run_sweep(make_job(**{"job.samples_per_n": 4}), out, evaluator=UnitConstantsEvaluator())
    _one_line(capsys, main(["explore", str(out), "--no-browser"]), 2, str(out), "tip_x")


def test_a_missing_chromium_is_named_not_skipped(monkeypatch, tmp_path):
    from dpfexplore.bench import explore as bench

    monkeypatch.setattr(bench, "CHROMIUM", tmp_path / "chromium")
    reason = bench.missing_chromium()
    assert reason.startswith(f"{tmp_path / 'chromium'} is missing") and "apt-get" in reason


_COUNT = "() => Bokeh.documents[0].get_model_by_name('count').text"


def test_the_page_in_chromium(data, finder, frame, tmp_path):
    """In Debian's Chromium: the count, a click at a known tip, the TOML, a filter, offline."""
    reason = missing_chromium()
    if reason:
        pytest.fail(f"the explorer's browser test cannot run: {reason}")
    from playwright.sync_api import sync_playwright

    running = start_server(data, finder=finder, background=True)
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


def test_ctrl_c_stops_the_server_in_one_line(dataset):
    """The command serves until Ctrl-C, then says so in one line and exits 0."""
    process = subprocess.Popen(
        [sys.executable, "-m", "dpfexplore", "explore", str(dataset), "--no-browser"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        line = process.stdout.readline()  # the address: the server listens
        url = re.search(r"at (http://127\.0\.0\.1:\d+/) \(Ctrl-C stops\)", line).group(1)
        with urllib.request.urlopen(url, timeout=30) as page:
            assert page.status == 200
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 0 and out == ""
    assert err.strip().splitlines() == [f"dpfexplore explore: stopped ({url})"]
