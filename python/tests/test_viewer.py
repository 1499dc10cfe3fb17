"""The run page view.html in a real browser: Debian's Chromium, headless, driven by Selenium.

`brachia plan`, `track`, `traverse` and `simulate` write view.html into their run folders and `brachia
view` writes it for a benchmark folder and a track folder without its plan; these tests open the pages
from disk and check what a user sees: no console error and no network request, the robot moving
between t = 0 and t = T/2 while the bars stay put, the hand on the target bar at t = T, play advancing
the time readout, the slider, a drag in a plot and the keys moving the time, the theme switching. They need BRACHIA_BIN (the built brachia binary),
the selenium package and Chromium with its driver (/usr/bin/chromium, /usr/bin/chromedriver); without
them they are skipped.
"""

import io
import json
import math
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
BIN = os.environ.get("BRACHIA_BIN")

webdriver = pytest.importorskip("selenium.webdriver")
if not (os.path.exists(CHROMIUM) and os.path.exists(CHROMEDRIVER)):
    pytest.skip("chromium and chromium-driver are not installed", allow_module_level=True)
if not BIN:
    pytest.skip("BRACHIA_BIN (the built brachia binary) not set", allow_module_level=True)

Image = pytest.importorskip("PIL.Image")

WIDTH, HEIGHT = 1280, 900
HAND = (0xD6, 0x24, 0x9F)


def brachia(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([BIN, *args], capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> dict:
    """A plan folder and a track folder of the paper's tracking swing (V-B)."""
    base = tmp_path_factory.mktemp("viewer")
    scenario = str(ROOT / "scenarios" / "tracking.toml")
    plan = brachia("plan", "--scenario", scenario, "--out", str(base / "plan"))
    assert plan.returncode == 0, plan.stderr
    track = brachia("track", "--scenario", scenario, "--out", str(base / "track"))
    assert track.returncode == 0, track.stderr
    return {"plan": base / "plan", "track": base / "track"}


LADDER = """name = "ladder-three"
params = "{params}"

[ladder]
bars = [{{ x = 0.0, y = 0.0 }}, {{ x = 1.0, y = 0.0 }}, {{ x = 2.0, y = 0.0 }}]
capture_radius = 0.02
capture_speed = 0.1

[planner]
swing_time = "auto"
knot_dt = 0.03
transcription = "multiple-shooting"

[planner.bounds]
qd_end_max = 1.0

[solver]
backend = "ocp"
"""


@pytest.fixture(scope="module")
def more(tmp_path_factory, runs) -> dict:
    """A traverse of three bars (two swings, one per hand), a passive simulation, a small benchmark
    folder and a track folder whose plan was read from elsewhere (no plan/ inside)."""
    base = tmp_path_factory.mktemp("viewer-more")
    ladder = base / "ladder.toml"
    ladder.write_text(LADDER.format(params=(ROOT / "params" / "paper.toml").as_posix()))
    r = brachia("traverse", "--scenario", str(ladder), "--out", str(base / "traverse"))
    assert r.returncode == 0, r.stderr
    r = brachia(
        "simulate", "--params", str(ROOT / "params" / "paper.toml"), "--q0", "-1.2,0.5,0.3,0.2",
        "--duration", "1.5", "--out", str(base / "simulate"),
    )
    assert r.returncode == 0, r.stderr
    scenario = str(ROOT / "scenarios" / "tracking.toml")
    r = brachia(
        "benchmark", "--scenario", scenario, "--out", str(base / "bench"), "--levels", "3",
        "--monte-carlo", "0", "--controller", "pd", "--controller", "open-loop",
        "--sweep", "mass", "--sweep", "actuation_delay", "--family-runs", "1", "--no-progress",
    )
    assert r.returncode in (0, 1), r.stderr
    r = brachia("view", str(base / "bench"))
    assert r.returncode == 0, r.stderr
    r = brachia(
        "track", "--scenario", scenario, "--plan", str(runs["plan"]), "--plant", "model",
        "--out", str(base / "track-no-plan"),
    )
    assert r.returncode == 0, r.stderr
    assert not (base / "track-no-plan" / "plan").exists()
    r = brachia("view", str(base / "track-no-plan"))
    assert r.returncode == 0, r.stderr
    r = brachia("track", "--scenario", str(ROOT / "scenarios" / "robustness.toml"), "--out", str(base / "ball"))
    assert r.returncode in (0, 1), r.stderr
    write_study(base / "study")
    r = brachia("view", str(base / "study"))
    assert r.returncode == 0, r.stderr
    return {k: base / k for k in ["traverse", "simulate", "bench", "track-no-plan", "ball", "study"]}


def write_study(dir: Path) -> None:
    """A parameter-study folder as a reproduction writes it (report.json, cells.csv, freefall.csv):
    3 r2 x 3 offsets of the paper's robot, the cell (r2 0.8, offset +0.5 s) not converged."""
    import tomllib

    dir.mkdir()
    base = tomllib.loads((ROOT / "params" / "paper.toml").read_text())
    r2s, offsets = [0.2, 0.5, 0.8], [-0.5, 0.0, 0.5]
    cells = ["# brachia cells schema 1",
             "r2,offset_s,swing_time_s,status,converged,energy_j,positive_work_j,objective,iterations,"
             "solve_time_s,start,replay_ee_error_m,torque_scale_reached"]
    rows = []
    for i, r2 in enumerate(r2s):
        for j, off in enumerate(offsets):
            ok = not (i == 2 and j == 2)
            e = f"{1.0 + i + 0.5 * j:.9f}" if ok else ""
            w = f"{2.0 + i + 0.5 * j:.9f}" if ok else ""
            cells.append(f"{r2},{off},{2.2 + off:.6f},{'solved' if ok else 'max_iterations'},"
                         f"{'true' if ok else 'false'},{e},{w},{e},{20 + j},0.5000,cold,1e-4,")
        rows.append({
            "r2": r2, "lengths_m": [0.71 * r2, 0.71 * (1 - r2), 0.71 * (1 - r2), 0.71 * r2],
            "start_q": [], "freefall_time_s": 1.1, "swing_time_s": 2.2, "energy_at_t_j": 1.5 + i,
            "argmin_swing_time_s": 1.7, "argmin_offset_s": -0.5, "min_energy_j": 1.0 + i,
            "argmin_at_edge": True, "failed_cells": 1 if i == 2 else 0,
        })
    (dir / "cells.csv").write_text("\n".join(cells) + "\n")
    (dir / "freefall.csv").write_text("# brachia freefall schema 1\nr2\n")
    report = {
        "schema_version": 1,
        "settings": {"base_params": {"inline": base}, "r2": r2s, "offsets_s": offsets, "stick_r2": []},
        "start_q": [-2.35, 0.0, -1.55, 0.0], "rows": rows, "cells": 9, "failed_cells": 1,
        "stick_r2": [], "wall_time_s": 3.0,
    }
    (dir / "report.json").write_text(json.dumps(report))


@pytest.fixture(scope="module")
def driver():
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="brachia-chromium-")
    opts = Options()
    opts.binary_location = CHROMIUM
    for flag in [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-dev-shm-usage",
        "--force-device-scale-factor=1",
        "--hide-scrollbars",
        f"--window-size={WIDTH},{HEIGHT}",
        f"--user-data-dir={profile}",
    ]:
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    d = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    d.set_window_size(WIDTH, HEIGHT)
    yield d
    d.quit()
    shutil.rmtree(profile, ignore_errors=True)


def open_page(driver, page: Path, t: float | None = None) -> None:
    url = page.resolve().as_uri() + ("" if t is None else f"#t={t}")
    driver.get("about:blank")
    driver.get(url)
    for _ in range(100):
        if driver.execute_script("return document.documentElement.dataset.ready === '1'"):
            return
        time.sleep(0.05)
    raise AssertionError(f"{url} did not finish drawing")


def screenshot(driver) -> Image.Image:
    return Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB")


def stage_rect(driver) -> tuple[int, int, int, int]:
    r = driver.execute_script(
        "const r = document.getElementById('stage').getBoundingClientRect();"
        "return [r.left, r.top, r.right, r.bottom];"
    )
    return tuple(int(round(v)) for v in r)


def hand_centroid(img: Image.Image, rect) -> tuple[float, float] | None:
    """Centre of the hand marker's pixels (its colour, HAND) inside the stage."""
    xs, ys = [], []
    px = img.load()
    for y in range(rect[1], min(rect[3], img.height)):
        for x in range(rect[0], min(rect[2], img.width)):
            p = px[x, y]
            if sum(abs(p[k] - HAND[k]) for k in range(3)) < 30:
                xs.append(x)
                ys.append(y)
    if len(xs) < 10:
        return None
    return sum(xs) / len(xs), sum(ys) / len(ys)


def region_diff(a: Image.Image, b: Image.Image, box) -> int:
    """Pixels that differ between a and b inside box (left, top, right, bottom)."""
    ca, cb = a.crop(box).tobytes(), b.crop(box).tobytes()
    ca, cb = zip(*[iter(ca)] * 3), zip(*[iter(cb)] * 3)
    return sum(1 for p, q in zip(ca, cb) if p != q)


def check_loads_quietly(driver, page: Path) -> None:
    """The page is under 3 MB, loads with no console error or warning and requests nothing."""
    assert page.is_file()
    size = page.stat().st_size
    assert size < 3_000_000, f"{page} is {size} bytes"
    driver.get_log("browser")
    driver.get_log("performance")
    open_page(driver, page)
    errors = [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert errors == [], errors
    urls = []
    for entry in driver.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg["method"] == "Network.requestWillBeSent":
            urls.append(msg["params"]["request"]["url"])
    page_url = page.resolve().as_uri()
    others = [u for u in urls if not u.startswith(page_url) and u != "about:blank"]
    assert others == [], others


@pytest.mark.parametrize("kind", ["plan", "track"])
def test_page_loads_without_errors_or_network(driver, runs, kind):
    page = runs[kind] / "view.html"
    check_loads_quietly(driver, page)
    assert driver.find_element("id", "time-readout").text.startswith("t = 0.000 s")


@pytest.mark.parametrize("kind", ["traverse", "simulate", "bench", "track-no-plan", "ball", "study"])
def test_other_pages_load_without_errors_or_network(driver, more, kind):
    check_loads_quietly(driver, more[kind] / "view.html")


def test_traverse_page_draws_the_whole_ladder_and_marks_the_switch(driver, more):
    page = more["traverse"] / "view.html"
    report = json.loads((more["traverse"] / "report.json").read_text())
    open_page(driver, page)
    assert driver.execute_script("return brachiaView.kind") == "traverse"
    T = driver.execute_script("return brachiaView.T")
    assert abs(T - report["totals"]["duration_s"]) < 1e-3
    assert driver.execute_script("return brachiaView.target") == [2.0, 0.0]
    shots = {}
    for label, t in [("start", 0.0), ("middle", T / 2), ("end", T)]:
        open_page(driver, page, t)
        shots[label] = screenshot(driver)
    rect = stage_rect(driver)
    # the hand ends on the last bar and starts far from it (world frame, the whole ladder in view)
    tx, ty = driver.execute_script("const b = brachiaView.target; return brachiaView.toPage(b[0], b[1]);")
    end = hand_centroid(shots["end"], rect)
    assert end is not None and abs(end[0] - tx) < 4 and abs(end[1] - ty) < 4, (end, tx, ty)
    start = hand_centroid(shots["start"], rect)
    assert start is not None and (start[0] - tx) ** 2 + (start[1] - ty) ** 2 > 150**2
    # after the grip switch the chain hangs from bar 1: the hand is the other end of the chain
    rows = (more["traverse"] / "traverse.csv").read_text().splitlines()
    head = rows[1].split(",")
    t_col, swing_col = head.index("t"), head.index("swing")
    cells = [r.split(",") for r in rows[2:]]
    k = next(i for i in range(1, len(cells)) if cells[i][swing_col] != cells[i - 1][swing_col])
    t_switch = float(cells[k][t_col])
    assert float(cells[k - 1][t_col]) == t_switch
    # before the switch the hand is on bar 1; just after it the hand is the other end, on bar 0
    before = driver.execute_script("return brachiaView.hand(arguments[0])", t_switch - 0.002)
    after = driver.execute_script("return brachiaView.hand(arguments[0])", t_switch + 0.002)
    assert math.dist(before, [1.0, 0.0]) < 0.03 and math.dist(after, [0.0, 0.0]) < 0.03, (before, after)
    # the switch is a mark in the plots, named in the tooltip near its time
    marks = driver.execute_script("return brachiaView.marks()")
    assert any("grip switch" in m["text"] and abs(m["t"] - t_switch) < 2e-3 for m in marks), marks
    out = os.environ.get("BRACHIA_VIEW_SHOTS")
    if out:
        shots["middle"].save(Path(out) / "traverse-middle.png")


def test_track_page_with_a_ball_marks_the_hit_and_moves_the_ball(driver, more):
    page = more["ball"] / "view.html"
    report = json.loads((more["ball"] / "report.json").read_text())
    hit = report["first_contact_s"]
    assert hit is not None
    open_page(driver, page)
    marks = driver.execute_script("return brachiaView.marks()")
    contacts = [m for m in marks if m["text"].startswith("contact")]
    assert contacts and abs(contacts[0]["t"] - hit) < 1e-3, marks
    # the ball, drawn where obstacles.csv puts it: it stands still before the hit and moves after it
    ball = report["plant_obstacles"][-1]
    assert ball["kind"] == "ball"
    bx, by = driver.execute_script("return brachiaView.toPage(arguments[0], arguments[1])", *ball["center"])
    box = (int(bx) - 6, int(by) - 6, int(bx) + 6, int(by) + 6)
    open_page(driver, page, 0)
    a = screenshot(driver)
    open_page(driver, page, hit * 0.5)
    b = screenshot(driver)
    T = driver.execute_script("return brachiaView.T")
    open_page(driver, page, T)
    c = screenshot(driver)
    assert region_diff(a, b, box) == 0
    assert region_diff(a, c, box) > 20


def test_simulate_page_moves_the_passive_chain(driver, more):
    page = more["simulate"] / "view.html"
    open_page(driver, page, 0)
    rect = stage_rect(driver)
    a = hand_centroid(screenshot(driver), rect)
    open_page(driver, page, 0.4)
    b = hand_centroid(screenshot(driver), rect)
    assert a is not None and b is not None and (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 > 10**2, (a, b)
    titles = driver.execute_script("return [...document.querySelectorAll('.plot h2')].map((h) => h.textContent)")
    assert any("mechanical energy" in t for t in titles), titles
    assert driver.execute_script("return brachiaView.target") is None


def test_track_page_without_its_plan_says_so_and_reaches_the_bar(driver, more):
    page = more["track-no-plan"] / "view.html"
    open_page(driver, page)
    notes = driver.find_element("id", "notes").text
    assert "holds no plan" in notes, notes
    T = driver.execute_script("return brachiaView.T")
    open_page(driver, page, T)
    rect = stage_rect(driver)
    tx, ty = driver.execute_script("const b = brachiaView.target; return brachiaView.toPage(b[0], b[1]);")
    end = hand_centroid(screenshot(driver), rect)
    assert end is not None and abs(end[0] - tx) < 4 and abs(end[1] - ty) < 4, (end, tx, ty)


def test_benchmark_page_shows_the_scorecard_and_a_curve_per_sweep(driver, more):
    page = more["bench"] / "view.html"
    open_page(driver, page)
    card = json.loads((more["bench"] / "scorecard.json").read_text())
    sweeps = [s["name"] for s in card["sweeps"]]
    shown = driver.execute_script("return [...document.querySelectorAll('figure.curve')].map((f) => f.dataset.sweep)")
    assert shown == sweeps
    rows = driver.execute_script("return document.querySelectorAll('table')[0].tBodies[0].rows.length")
    assert rows == len(card["controllers"])
    # one point per controller and level, each naming its run on hover
    points = driver.execute_script("return [...document.querySelectorAll('circle.pt title')].map((t) => t.textContent)")
    assert len(points) == len(card["controllers"]) * sum(len(s["levels"]) for s in card["sweeps"])
    assert all(("success" in p) != ("failure" in p) for p in points), points


def test_benchmark_page_shows_success_per_family_with_its_runs(driver, more):
    page = more["bench"] / "view.html"
    open_page(driver, page)
    card = json.loads((more["bench"] / "scorecard.json").read_text())
    sweeps = {s["name"] for s in card["sweeps"]}
    families = sorted({k for c in card["controllers"] for k in c["per_disturbance"] if k not in sweeps})
    assert len(families) >= 7, families
    shown = driver.execute_script("return [...document.querySelectorAll('#families tbody tr')].map((r) => r.dataset.family)")
    assert sorted(shown) == families
    # a bar per controller and family, its height the success rate, its title the rate and the runs
    bars = driver.execute_script(
        "return [...document.querySelectorAll('#family-chart rect.bar')].map((b) => ["
        "b.dataset.controller, b.dataset.family, b.getBoundingClientRect().height, "
        "b.querySelector('title').textContent])"
    )
    assert len(bars) == len(card["controllers"]) * len(families)
    per_pct = []
    for controller, family, height, title in bars:
        score = next(c for c in card["controllers"] if c["controller"] == controller)["per_disturbance"][family]
        assert f"{score['success_pct']:.1f} % of {score['runs']} run" in title, title
        if score["success_pct"] > 0:
            per_pct.append(height / score["success_pct"])
        else:
            assert height < 4, (title, height)
    # every bar of a success rate above 0 is drawn to the same scale
    assert all(abs(r - per_pct[0]) < 0.03 * per_pct[0] for r in per_pct[1:]), per_pct
    # the figure beside the other benchmark figures
    assert (more["bench"] / "success_by_family.png").is_file()
    assert (more["bench"] / "success_by_family.svg").is_file()


def test_study_page_shows_the_grid_and_hovering_a_cell_shows_its_value(driver, more):
    from selenium.webdriver.common.action_chains import ActionChains

    page = more["study"] / "view.html"
    open_page(driver, page)
    cells = driver.find_elements("css selector", "#energy-map g.cell")
    assert len(cells) == 9
    tip = driver.find_element("id", "tip")
    assert not tip.is_displayed()
    cell = next(c for c in cells if c.get_attribute("data-r2") == "0.5" and c.get_attribute("data-offset") == "0")
    ActionChains(driver).move_to_element(cell).perform()
    assert tip.is_displayed()
    assert tip.text.startswith("r2 = 0.5, offset +0 s (swing time 2.200 s): energy 2.5 J, positive work 3.5 J"), tip.text
    # the failed cell says so; a point of the energy curves shows its cell
    failed = next(c for c in cells if c.get_attribute("data-r2") == "0.8" and c.get_attribute("data-offset") == "0.5")
    ActionChains(driver).move_to_element(failed).perform()
    assert "did not converge (max_iterations)" in tip.text, tip.text
    points = driver.find_elements("css selector", "#energy-curves circle.pt")
    assert len(points) == 8
    ActionChains(driver).move_to_element(points[0]).perform()
    assert "energy" in tip.text and " J" in tip.text, tip.text
    # keyboard: focusing a cell shows its value too
    driver.execute_script("arguments[0].focus()", cells[0])
    assert tip.is_displayed() and tip.text.startswith("r2 = 0.2"), tip.text
    # cells of different values differ in colour, the failed cell is hatched
    fills = {c.get_attribute("data-value"): c.find_element("css selector", "rect").get_attribute("fill") for c in cells}
    assert fills["1"] != fills["3.5"] and fills[""].startswith("url(")
    out = os.environ.get("BRACHIA_VIEW_SHOTS")
    if out:
        ActionChains(driver).move_to_element(cell).perform()
        screenshot(driver).save(Path(out) / "study.png")


@pytest.mark.parametrize("kind", ["plan", "track"])
def test_robot_moves_bars_stay_and_hand_reaches_the_target(driver, runs, kind, tmp_path):
    page = runs[kind] / "view.html"
    open_page(driver, page)
    T = driver.execute_script("return brachiaView.T")
    assert T > 0.5
    shots = {}
    for label, t in [("start", 0.0), ("middle", T / 2), ("end", T)]:
        open_page(driver, page, t)
        assert abs(driver.execute_script("return brachiaView.time()") - t) < 1e-3
        shots[label] = screenshot(driver)
    rect = stage_rect(driver)
    # the robot moved: the stage differs between t = 0 and t = T/2, around the hand at T/2 ...
    hx, hy = driver.execute_script("const h = brachiaView.hand(arguments[0]); return brachiaView.toPage(h[0], h[1]);", T / 2)
    box = (int(hx) - 12, int(hy) - 12, int(hx) + 12, int(hy) + 12)
    assert region_diff(shots["start"], shots["middle"], box) > 50
    # ... and the hand marker is where the page's transform says the hand is
    mid = hand_centroid(shots["middle"], rect)
    assert mid is not None and abs(mid[0] - hx) < 2.5 and abs(mid[1] - hy) < 2.5, (mid, hx, hy)
    # the target bar is drawn the same at both times (the hand is far from it)
    tx, ty = driver.execute_script("const b = brachiaView.target; return brachiaView.toPage(b[0], b[1]);")
    bar = (int(tx) - 12, int(ty) - 12, int(tx) + 12, int(ty) + 12)
    assert region_diff(shots["start"], shots["middle"], bar) == 0
    assert region_diff(shots["start"], shots["end"], bar) > 20
    # the hand at T lies within a few pixels of the target bar
    end = hand_centroid(shots["end"], rect)
    assert end is not None and abs(end[0] - tx) < 4 and abs(end[1] - ty) < 4, (end, tx, ty)
    start = hand_centroid(shots["start"], rect)
    assert start is not None and (start[0] - tx) ** 2 + (start[1] - ty) ** 2 > 100**2
    out = os.environ.get("BRACHIA_VIEW_SHOTS")
    if out:
        for label, img in shots.items():
            img.save(Path(out) / f"{kind}-{label}.png")


def test_play_advances_the_time_readout(driver, runs):
    open_page(driver, runs["track"] / "view.html", 0)
    before = driver.find_element("id", "time-readout").text
    driver.find_element("id", "play").click()
    time.sleep(0.6)
    assert driver.execute_script("return brachiaView.playing()")
    after = driver.find_element("id", "time-readout").text
    t = float(after.split()[2])
    assert after != before and t > 0.1, (before, after)
    driver.find_element("id", "play").click()
    assert not driver.execute_script("return brachiaView.playing()")


def test_dragging_the_slider_moves_the_robot(driver, runs):
    from selenium.webdriver.common.action_chains import ActionChains

    open_page(driver, runs["track"] / "view.html", 0)
    rect = stage_rect(driver)
    before = hand_centroid(screenshot(driver), rect)
    slider = driver.find_element("id", "slider")
    width = slider.size["width"]
    ActionChains(driver).move_to_element_with_offset(slider, -width // 2 + 2, 0).click_and_hold().move_by_offset(
        width // 2, 0
    ).release().perform()
    t = driver.execute_script("return brachiaView.time()")
    T = driver.execute_script("return brachiaView.T")
    assert 0.2 * T < t < 0.8 * T, t
    assert driver.find_element("id", "time-readout").text.startswith(f"t = {t:.3f} s")
    after = hand_centroid(screenshot(driver), rect)
    assert before is not None and after is not None
    assert (before[0] - after[0]) ** 2 + (before[1] - after[1]) ** 2 > 20**2, (before, after)


def test_keys_step_frames_and_jump_to_the_ends(driver, runs):
    from selenium.webdriver.common.keys import Keys

    open_page(driver, runs["track"] / "view.html", 0)
    body = driver.find_element("tag name", "body")
    body.send_keys(Keys.ARROW_RIGHT)
    t1 = driver.execute_script("return brachiaView.time()")
    assert 0.005 < t1 < 0.015, t1
    body.send_keys(Keys.END)
    T = driver.execute_script("return brachiaView.T")
    assert driver.execute_script("return brachiaView.time()") == T
    body.send_keys(Keys.ARROW_LEFT)
    assert T - 0.015 < driver.execute_script("return brachiaView.time()") < T
    body.send_keys(Keys.HOME)
    assert driver.execute_script("return brachiaView.time()") == 0
    assert driver.current_url.endswith("#t=0.000")


def test_dragging_in_a_plot_moves_the_time_and_shows_values(driver, runs):
    from selenium.webdriver.common.action_chains import ActionChains

    open_page(driver, runs["track"] / "view.html", 0)
    canvases = driver.find_elements("css selector", ".plot canvas")
    assert len(canvases) >= 5
    last = canvases[-1]
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", last)
    width = last.size["width"]
    ActionChains(driver).move_to_element_with_offset(last, -width // 4, 0).click_and_hold().move_by_offset(
        width // 4, 0
    ).perform()
    tip = driver.find_element("id", "tip")
    assert tip.is_displayed() and "t = " in tip.text
    ActionChains(driver).release().perform()
    t = driver.execute_script("return brachiaView.time()")
    T = driver.execute_script("return brachiaView.T")
    # the press and the drag both set the time; the release leaves it mid-plot
    assert 0.3 * T < t < 0.7 * T, (t, T)


def test_the_theme_button_switches_light_and_dark(driver, runs):
    open_page(driver, runs["track"] / "view.html", 0)
    bg = lambda: driver.execute_script("return getComputedStyle(document.body).backgroundColor")
    before = bg()
    driver.find_element("id", "theme").click()
    after = bg()
    assert before != after
    driver.find_element("id", "theme").click()
    assert bg() == before


def test_bad_folder_is_refused_naming_the_file(runs, tmp_path):
    bad = tmp_path / "plan"
    shutil.copytree(runs["plan"], bad)
    (bad / "view.html").unlink()
    csv = bad / "trajectory.csv"
    lines = csv.read_text().splitlines()
    lines[5] = lines[5].replace(lines[5].split(",")[1], "nan", 1)
    csv.write_text("\n".join(lines) + "\n")
    before = sorted((p.name, p.stat().st_mtime_ns) for p in bad.iterdir())
    r = brachia("view", str(bad))
    assert r.returncode == 2, r.stderr
    assert "trajectory.csv" in r.stderr
    assert sorted((p.name, p.stat().st_mtime_ns) for p in bad.iterdir()) == before
