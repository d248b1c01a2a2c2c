"""``dpfexplore bench explore``: the explorer's page timed in headless Chromium on a million rows.

What it runs, on one sweep dataset (default ``results/explore-million``, made from
``jobs/explore-million.toml`` - the paper's ranges, N = 2..6, 8,100 designs each, every state:
1,004,400 rows - by a ``dpfexplore sweep`` of about four minutes when it is missing):

* the dataset read (every chunk checked against its SHA-256) and the lookup index opened;
* the server started on 127.0.0.1, then Debian's Chromium (``/usr/bin/chromium``, driven by
  Playwright; no browser is downloaded) opens the page twice: the first full render after the
  server starts (cold: nothing cached) and again, reloaded (warm); each time from the
  navigation's start to the painted map, by the browser's clock (``performance.now()``).
  Goal: warm <= 5 s;
* ``--zooms`` zoom steps (a mouse-wheel notch at the frame's centre) and pans, each from the
  browser's wheel event to the repainted map image. Goal: median <= 300 ms;
* ``--clicks`` clicks at tips of ``ok`` rows, each from the browser's pointer event to the
  painted designs (nearest rows under the filters, refined to 1e-6 mm by the exact model,
  re-solved). Goal: median <= 500 ms;
* the server's memory (the resident set of this process, which runs it) and every request
  the page made: all to 127.0.0.1.

``--screenshot`` saves the page after a click (the guide's figure).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from ._common import REPORTS, count, dataset_options, emit, machine_info

JOBS = Path(__file__).resolve().parents[2] / "jobs"
DEFAULT_DATASET = Path("results") / "explore-million"
#: Debian's Chromium, the only browser the benchmark and the tests drive.
CHROMIUM = Path("/usr/bin/chromium")
#: Seconds between two clicks: BokehJS takes two taps within 300 ms for a double tap.
DOUBLE_TAP_S = 0.35
#: Flags of a headless Chromium run as root in a container, with nothing reaching out.
CHROMIUM_FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
)
#: JavaScript: the map's image is in place and painted (resolves with performance.now()).
_MAP_READY = """() => new Promise(resolve => {
  const ready = () => window.Bokeh && Bokeh.documents.length
    && Bokeh.documents[0].get_model_by_name('raster')
    && Bokeh.documents[0].get_model_by_name('raster').data.image.length == 1
    && Bokeh.index.get_one(Bokeh.documents[0].get_model_by_name('map'));
  const poll = () => ready() ? requestAnimationFrame(() => resolve(performance.now()))
                             : setTimeout(poll, 5);
  poll();
})"""
#: JavaScript: arm a timer from the next wheel/pointer event to the next change of a model.
_ARM = """([name, kind]) => {
  const model = Bokeh.documents[0].get_model_by_name(name);
  window.__dpf = {start: null, end: null};
  const start = e => { if (window.__dpf.start === null) window.__dpf.start = e.timeStamp; };
  document.addEventListener(kind, start, {capture: true, once: true});
  const signal = model.change;
  const done = () => requestAnimationFrame(() => {
    if (window.__dpf.end === null) window.__dpf.end = performance.now(); });
  signal.connect(done);
}"""
#: JavaScript: resolve after two animation frames (the page has drawn what it received).
_IDLE = "() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))"
_FIRED = "() => window.__dpf.end !== null && window.__dpf.start !== null"
_ELAPSED = "() => window.__dpf.end - window.__dpf.start"
#: JavaScript: page coordinates of the data point (x, y) mm on the map.
_TO_PAGE = """([x, y]) => {
  const view = Bokeh.index.get_one(Bokeh.documents[0].get_model_by_name('map'));
  const box = view.el.getBoundingClientRect();
  return [box.left + view.frame.x_scale.compute(x), box.top + view.frame.y_scale.compute(y),
          box.left + view.frame.bbox.hcenter, box.top + view.frame.bbox.vcenter];
}"""


def missing_chromium() -> str | None:
    """Why Chromium cannot be driven here (None when it can)."""
    if not CHROMIUM.is_file():
        return (
            f"{CHROMIUM} is missing: install Debian's browser (apt-get install -y chromium "
            "chromium-driver); the explorer's browser checks need it"
        )
    try:
        import playwright  # noqa: F401
    except ImportError:
        return "the Python package playwright is missing: pip install -e '.[test]'"
    return None


def launch(playwright, user_data_dir: Path):
    """A fresh headless Chromium context (its own profile directory)."""
    return playwright.chromium.launch_persistent_context(
        str(user_data_dir),
        executable_path=str(CHROMIUM),
        headless=True,
        args=list(CHROMIUM_FLAGS),
        viewport={"width": 1480, "height": 900},
        accept_downloads=True,
    )


def wait_for_map(page) -> float:
    """Wait until the map is painted; the browser's milliseconds since navigation start."""
    return float(page.evaluate(_MAP_READY))


def page_point(page, x: float, y: float) -> tuple[float, float, float, float]:
    """Page pixels of the data point ``(x, y)`` (mm) and of the map frame's centre."""
    return tuple(page.evaluate(_TO_PAGE, [x, y]))


def timed(page, model: str, kind: str, gesture) -> float:
    """Milliseconds from the browser's ``kind`` event to the repaint after ``model`` changes."""
    page.evaluate(_ARM, [model, kind])
    page.evaluate(_IDLE)
    gesture()
    page.wait_for_function(_FIRED, timeout=60_000)
    return float(page.evaluate(_ELAPSED))


def register(subparsers) -> None:
    """Add ``bench explore``."""
    parser = subparsers.add_parser(
        "explore",
        help="the explorer's page in headless Chromium: first render, zoom, click to designs",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--save",
        action="store_true",
        help=f"also write the record to {REPORTS}/bench-explore.json and .md",
    )
    dataset_options(parser, DEFAULT_DATASET, JOBS / "explore-million.toml")
    parser.add_argument("--zooms", type=count(1), default=12, help="zoom and pan steps timed")
    parser.add_argument("--clicks", type=count(1), default=12, help="clicks timed")
    parser.add_argument("--seed", type=int, default=0, help="seed of the clicked rows")
    parser.add_argument("--screenshot", type=Path, help="save the page after a click (PNG)")
    parser.set_defaults(handler=run)


def _ensure_dataset(args) -> float | None:
    from ..sweep.driver import run_sweep
    from ..sweep.job_file import load_job

    if (args.dataset / "_manifest.json").exists():
        return None
    print(f"bench explore: making {args.dataset} from {args.job} (minutes) ...", flush=True)
    start = time.perf_counter()
    run_sweep(load_job(args.job), args.dataset)
    return time.perf_counter() - start


def _summary(values: list[float]) -> dict[str, float]:
    return {
        "median_ms": statistics.median(values),
        "p90_ms": float(np.percentile(values, 90)),
        "max_ms": max(values),
        "runs_ms": values,
    }


def _browse(args, running, data, rng) -> dict[str, Any]:
    import tempfile

    from playwright.sync_api import sync_playwright

    out: dict[str, Any] = {}
    requests: list[str] = []
    errors: list[str] = []
    with sync_playwright() as p, tempfile.TemporaryDirectory() as profile:
        context = launch(p, Path(profile))
        context.on("request", lambda r: requests.append(r.url))
        page = context.pages[0] if context.pages else context.new_page()
        page.on("console", lambda m: m.type == "error" and errors.append(m.text))
        page.goto(running.url)
        out["first_render_cold_ms"] = wait_for_map(page)
        page.goto(running.url)  # again: BokehJS from the browser's cache, a new session
        out["first_render_warm_ms"] = wait_for_map(page)
        _, _, cx, cy = page_point(page, 0.0, 0.0)
        zooms = []
        for i in range(args.zooms):
            page.mouse.move(cx, cy)
            delta = -200 if i % 3 != 2 else 200
            zooms.append(timed(page, "raster", "wheel", lambda d=delta: page.mouse.wheel(0, d)))
        out["zoom"] = _summary(zooms)
        page.goto(running.url)  # the first view again
        wait_for_map(page)
        ok = np.flatnonzero((data.status == 0) & np.all(np.isfinite(data.tip), axis=1))
        clicks, server = [], []
        for i in rng.choice(ok, size=args.clicks, replace=False):
            px, py, _, _ = page_point(page, *data.tip[i])
            time.sleep(DOUBLE_TAP_S)  # two clicks within 0.3 s are BokehJS's double tap
            click = lambda x=px, y=py: page.mouse.click(x, y)  # noqa: E731
            clicks.append(timed(page, "details", "pointerdown", click))
            server.append(running.pages[-1].session.last_tap.seconds * 1e3)
        out["click"] = _summary(clicks)
        out["click"]["server_median_ms"] = statistics.median(server)
        out["picks_ok"] = sum(
            p.candidate.status == "ok" for p in running.pages[-1].session.last_tap.picks
        )
        if args.screenshot:
            args.screenshot.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(args.screenshot), full_page=True)
        context.close()
    hosts = sorted({u.split("/")[2] for u in requests if "://" in u and not u.startswith("data:")})
    out["request_hosts"] = hosts
    out["console_errors"] = errors
    return out


def run(args: argparse.Namespace) -> int:
    """Time the page; print (and with ``--save`` write) the record."""
    import psutil

    from ..explore.data import load_dataset
    from ..explore.designs import DesignFinder
    from ..explore.server import start_server

    reason = missing_chromium()
    if reason:
        raise SystemExit(f"dpfexplore bench explore: {reason}")
    sweep_s = _ensure_dataset(args)
    process = psutil.Process()
    start = time.perf_counter()
    data = load_dataset(args.dataset)
    load_s = time.perf_counter() - start
    start = time.perf_counter()
    finder = DesignFinder(data)
    index_s = time.perf_counter() - start
    rss_loaded = process.memory_info().rss / 1e6
    start = time.perf_counter()
    running = start_server(data, finder=finder, background=True)
    server_s = time.perf_counter() - start
    try:
        browse = _browse(args, running, data, np.random.default_rng(args.seed))
    finally:
        rss_served = process.memory_info().rss / 1e6
        running.stop()
    record = {
        "benchmark": "explore",
        "machine": machine_info(),
        "load": psutil.getloadavg(),
        "dataset": {
            "path": str(args.dataset),
            "rows": len(data),
            "designs": data.info.designs_committed,
            "sweep_s": sweep_s,
        },
        "load_s": load_s,
        "index_s": index_s,
        "index_action": finder.origin.action,
        "server_start_s": server_s,
        **browse,
        "server_rss_mb": {"loaded": rss_loaded, "after_browsing": rss_served},
        "goals": {
            "first_render_warm_ms": 5000.0,
            "zoom_median_ms": 300.0,
            "click_median_ms": 500.0,
        },
        "goals_met": {
            "first_render_warm": browse["first_render_warm_ms"] <= 5000.0,
            "zoom": browse["zoom"]["median_ms"] <= 300.0,
            "click": browse["click"]["median_ms"] <= 500.0,
            "offline": browse["request_hosts"] == [f"127.0.0.1:{running.port}"],
        },
    }
    record["command"] = (
        "dpfexplore bench explore --save"
        + (f" --dataset {args.dataset}" if args.dataset != DEFAULT_DATASET else "")
        + (f" --screenshot {args.screenshot}" if args.screenshot else "")
    )
    text = _text(record)
    if args.save:
        (REPORTS / "bench-explore.md").parent.mkdir(parents=True, exist_ok=True)
        (REPORTS / "bench-explore.md").write_text(text + "\n")
    emit(
        record,
        as_json=args.json,
        text=text,
        save=REPORTS / "bench-explore.json" if args.save else None,
    )
    return 0


def _text(r: dict[str, Any]) -> str:
    m = r["machine"]
    return "\n".join(
        [
            "# bench explore: the explorer's page in headless Chromium",
            "",
            f"Machine: {m['cpu']}, {m['cores']} cores, {m['date']}; load average "
            f"{', '.join(f'{v:.2f}' for v in r['load'])}. Command: `{r['command']}`.",
            "",
            f"Dataset: {r['dataset']['path']}, {r['dataset']['rows']:,} rows of "
            f"{r['dataset']['designs']:,} designs"
            + (
                f", made now by its sweep in {r['dataset']['sweep_s']:.0f} s."
                if r["dataset"]["sweep_s"]
                else "."
            ),
            "",
            "| step | measured | goal |",
            "| --- | --- | --- |",
            f"| dataset read, every chunk's SHA-256 checked | {r['load_s']:.2f} s | |",
            f"| lookup index ({r['index_action']}) | {r['index_s']:.2f} s | |",
            f"| server start | {r['server_start_s']:.2f} s | |",
            f"| first full render, cold | {r['first_render_cold_ms']:.0f} ms | |",
            f"| first full render, warm | {r['first_render_warm_ms']:.0f} ms | <= 5000 ms |",
            f"| zoom/pan re-render (median, p90) | {r['zoom']['median_ms']:.0f}, "
            f"{r['zoom']['p90_ms']:.0f} ms | <= 300 ms |",
            f"| click to verified designs (median, p90) | {r['click']['median_ms']:.0f}, "
            f"{r['click']['p90_ms']:.0f} ms (server {r['click']['server_median_ms']:.0f} ms) "
            "| <= 500 ms |",
            f"| server memory (RSS) | {r['server_rss_mb']['loaded']:.0f} MB loaded, "
            f"{r['server_rss_mb']['after_browsing']:.0f} MB after browsing | |",
            f"| hosts the page requested | {', '.join(r['request_hosts'])} | 127.0.0.1 only |",
            f"| console errors | {len(r['console_errors'])} | 0 |",
            "",
            "Times in the browser run from its own event (navigation start, wheel, pointer "
            "down) to the next animation frame after the map image or the designs pane changed.",
        ]
    )
