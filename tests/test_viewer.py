"""The browser replay viewer (referee/media/viewer.py, referee/web/) in a real headless Chromium:
it plays and seeks, opens other replays, and draws the frame pygame draws (arena/draw.py).

Chromium is Debian's (`apt-get install -y chromium`, /usr/bin/chromium) driven by playwright;
the browser tests skip, saying so, only where no chromium is installed.
"""

import base64
import gzip
import io
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pygame
import pytest
from helpers import MINI_LEVEL, edited, run_cli

import levels
from arena.draw import BEACON, Painter, color
from levels.loader import parse_level
from referee.match.loop import play_match
from referee.media.render import Scenes
from referee.media.viewer import write_viewer
from referee.records.replay_reader import load
from referee.sandbox.teams import resolve

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
SIZE = (960, 640)
WAIT_MS = 30_000  # the bound on every wait for the page

# Debug drawings of every kind, and an estimate off the truth by a known amount (20 mm, 10 mm, 0.1 rad).
DRAWING_BOT = """
from robots.api import Command, Drawing
from robots.controllers.dead_reckoning import DeadReckoning


class DrawingBot(DeadReckoning):
    def step(self, observation):
        cmd = super().step(observation)
        if cmd.estimate is None:
            return cmd
        x, y, h = cmd.estimate
        tx, ty = self.path[min(self.target, len(self.path) - 1)]
        return Command(cmd.left, cmd.right, estimate=(x + 0.02, y - 0.01, h + 0.1), debug=(
            Drawing("line", ((x, y), (tx, ty)), color=(20, 160, 120)),
            Drawing("circle", ((x, y),), radius=0.09, color=(200, 0, 200)),
            Drawing("text", ((x + 0.06, y + 0.08),), text=f"wp {self.target}", color=(10, 10, 120)),
            Drawing("point", ((tx, ty),), color=(250, 120, 0))))
"""

OBSTACLES = """obstacles:
  - {kind: box, center: [3, 15], size: [2, 1], angle: 30}
  - {kind: circle, center: [10, 12], radius: 0.8}
  - {kind: polygon, points: [[2, 3], [4, 3], [3, 5]]}
"""


def _short(name: str, seconds: float, extra: str = "", rules: str = "") -> bytes:
    text = re.sub(r"time_limit: *[0-9.]+", f"time_limit: {seconds}", levels.path(name).read_text())
    text = re.sub(r"\nrules: *(#[^\n]*)?\n", "\nrules:\n" + rules, text, count=1)
    return text.replace("beacons:", extra + "beacons:", 1).encode()


# the mini table as a goto task, the goal on the robot's line: driving blind, it arrives
GOTO_LEVEL = edited(
    MINI_LEVEL, {"task": {"kind": "goto", "radius": 0.2, "accuracy": 0.05, "goal": [1.5, 0.5]}, "time_limit": 20}
)


@pytest.fixture(scope="module")
def replays(tmp_path_factory):
    """Short replays of every beacon kind: four racing robots with debug drawings and a speed
    limit they break (sensor arrays), reflectors with obstacles of every shape, flash detectors, lights."""
    d = tmp_path_factory.mktemp("viewer")
    (d / "drawing_bot.py").write_text(DRAWING_BOT)
    bot = resolve(str(d / "drawing_bot.py"))
    out = {}
    for key, data, teams in (
        (
            "race",
            re.sub(
                r"\n    placement: \{[^}]*\}", "", _short("asabe-race", 6, rules="  speed_limit: 0.1\n").decode()
            ).encode(),
            [bot, bot, resolve("ref:dead-reckoning"), resolve("ref:bac")],
        ),
        ("vannoy", _short("vannoy", 3, OBSTACLES), [resolve("ref:vannoy")]),
        ("simi", _short("simi", 2), [resolve("ref:simi")]),
        ("osentoski", _short("osentoski", 2), [resolve("ref:osentoski")]),
        ("line", levels.path("bac-line").read_bytes(), [resolve("ref:bac")]),  # waypoints weighed by the path
        ("goto", GOTO_LEVEL.encode(), [resolve("ref:dead-reckoning")]),  # a blind drive that stops on its goal
    ):
        out[key] = d / f"{key}.replay"
        play_match(parse_level(data, f"{key}.yaml"), teams, replay=out[key], isolate=False)
    return out


@pytest.fixture(scope="module")
def browser():
    if not Path(CHROMIUM).exists():
        pytest.skip("no chromium installed (apt-get install -y chromium): the browser viewer is not tested here")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


def _open(browser, html: Path):
    """Open a page from file://, refusing (and recording) any request that is not a local file."""
    page = browser.new_page(viewport={"width": 1600, "height": 1000})
    page.errors, page.remote = [], []
    page.on("pageerror", lambda e: page.errors.append(str(e)))

    def route(r):
        if r.request.url.startswith(("file:", "data:")):
            r.continue_()
        else:
            page.remote.append(r.request.url)
            r.abort()

    page.route("**/*", route)
    page.goto(html.as_uri())
    page.wait_for_function("window.viewer && window.viewer.ready", timeout=WAIT_MS)
    return page


def _canvas(page) -> np.ndarray:
    """The canvas's own pixels (not a scaled screenshot), as pygame's surfarray: [x, y, rgb]."""
    url = page.evaluate("document.getElementById('view').toDataURL('image/png')")
    surface = pygame.image.load(io.BytesIO(base64.b64decode(url.split(",", 1)[1])), "canvas.png")
    return pygame.surfarray.array3d(surface).astype(int)


def _pygame(replay: Path, t: float) -> tuple[np.ndarray, Painter, Scenes]:
    scenes = Scenes(load(replay))
    painter = Painter(scenes.level, SIZE)
    surface = pygame.Surface(SIZE)
    painter.draw(surface, scenes.at(t))
    return pygame.surfarray.array3d(surface).astype(int), painter, scenes


def _centroid(img: np.ndarray, centre: tuple[float, float], radius: float, rgb, tol: float = 20.0):
    """Mean position of the pixels within `radius` of `centre` whose colour is within `tol` of `rgb`."""
    xs, ys = np.meshgrid(np.arange(img.shape[0]), np.arange(img.shape[1]), indexing="ij")
    near = (xs - centre[0]) ** 2 + (ys - centre[1]) ** 2 <= radius**2
    match = near & (np.linalg.norm(img - np.array(rgb), axis=2) <= tol)
    assert match.sum() >= 5, (centre, rgb)
    return float(xs[match].mean()), float(ys[match].mean())


def test_page_plays_seeks_and_steps(replays, browser, tmp_path):
    html = tmp_path / "race.html"
    proc = run_cli("render", str(replays["race"]), "--html", str(html))
    assert proc.returncode == 0, proc.stderr
    rep = load(replays["race"])
    page = _open(browser, html)
    assert page.evaluate("window.viewer.error") is None
    assert page.evaluate("window.viewer.duration") == pytest.approx(rep.duration)
    assert page.evaluate("window.viewer.time") == 0

    page.click("#play")  # the page's own button
    page.wait_for_function("window.viewer.time > 1.0", timeout=WAIT_MS)
    assert float(page.get_attribute("#view", "data-time")) > 0
    page.click("#play")  # pause: the clock stands still over the next animation frames
    held = page.evaluate("window.viewer.time")
    page.evaluate(
        "new Promise(r => { let n = 0; const f = () => (++n < 5 ? requestAnimationFrame(f) : r()); requestAnimationFrame(f); })"
    )
    assert page.evaluate("window.viewer.time") == held

    # the timeline slider seeks, and the robots are drawn where the replay's frame puts them
    page.evaluate(
        "(() => { const s = document.getElementById('slider'); s.value = '2.5';"
        " s.dispatchEvent(new Event('input')); })()"
    )
    assert page.evaluate("window.viewer.time") == 2.5
    assert page.get_attribute("#view", "data-time") == "2.5000"
    img = _canvas(page)
    painter = Painter(Scenes(rep).level, SIZE)
    frame = rep.frames[round(2.5 * rep.header["record_rate"])][1]
    for slot, (x, y, h) in enumerate(frame):
        # a point inside the body, away from the heading tick and the slot label
        px, py = painter.to_screen(
            x - 0.03 * math.cos(h) + 0.025 * math.sin(h), y - 0.03 * math.sin(h) - 0.025 * math.cos(h)
        )
        assert tuple(img[px, py]) == color(slot), slot

    # the panel: each robot's latest estimate against the true pose at the tick it was reported
    rows = page.locator("#now tr").all_inner_texts()
    for slot in range(len(frame)):
        est = [e for e in rep.estimates if e["r"] == slot and e["t"] <= 2.5][-1]
        tx, ty, th = rep.frames[round(est["t"] * rep.header["record_rate"])][1][slot]  # ticks fall on frames here
        ex, ey, eh = est["e"]
        turn = abs((eh - th + math.pi) % (2 * math.pi) - math.pi)
        assert f"{1000 * math.hypot(ex - tx, ey - ty):.1f}, {math.degrees(turn):.1f}" in rows[1 + slot], rows
    # and the HUD's line per robot says what referee/media/standings.py says (score so far, waypoints, error)
    hud = page.evaluate("window.viewer.scenes.at(window.viewer.time).hud")
    assert hud == list(Scenes(rep).at(2.5).hud)
    assert page.locator("#final tr").count() == 1 + len(frame)

    # every foul and fault is a mark on the timeline and a line in the list; a click seeks to it
    incidents = sorted([f["time"] for f in rep.fouls] + [f["time"] for f in rep.faults])
    assert len(rep.fouls) >= 2 and page.locator("#marks span").count() == len(incidents)
    page.locator("#incidents li").nth(1).click()
    assert page.evaluate("window.viewer.time") == incidents[1]
    assert f"fouls {sum(f['time'] <= incidents[1] for f in rep.fouls)}" in page.evaluate(
        "window.viewer.scenes.at(window.viewer.time).hud[0]"
    )
    page.evaluate("window.viewer.seek(2.5)")

    page.keyboard.press("ArrowRight")  # one frame on, while paused
    assert page.evaluate("window.viewer.time") == pytest.approx(2.5 + 1 / rep.header["record_rate"])
    page.keyboard.press("End")
    assert page.evaluate("window.viewer.time") == pytest.approx(rep.duration)
    page.keyboard.press("Home")
    page.keyboard.press(" ")  # space plays (the Play button, clicked before, must not take it as a click)
    page.wait_for_function("window.viewer.playing && window.viewer.time > 0.2", timeout=WAIT_MS)
    page.keyboard.press(" ")
    assert page.evaluate("window.viewer.playing") is False
    assert page.errors == [] and page.remote == []


def test_task_progress_follows_the_result(replays, browser, tmp_path):
    """Waypoints reached at a time are the result's `reached_at` times up to it."""
    rep = load(replays["race"])
    reached = {r["slot"]: r["task"]["reached_at"] for r in rep.result["robots"]}
    slot, times = max(reached.items(), key=lambda kv: len(kv[1]))
    assert times, "no robot reached a waypoint in the test match"
    html = tmp_path / "race.html"
    write_viewer(replays["race"], html)
    page = _open(browser, html)
    total = rep.result["robots"][slot]["task"]["total"]
    for t, count in ((times[0] - 0.05, 0), (times[0] + 0.05, 1), (rep.duration, len(times))):
        page.evaluate(f"window.viewer.seek({t})")
        row = page.locator("#now tr").nth(1 + slot).inner_text()
        assert f"{count} / {total} reached" in row, (t, row)


@pytest.mark.parametrize("key", ["race", "line", "goto"])
def test_score_so_far_counts_only_what_was_earned(replays, browser, tmp_path, key):
    """At t = 0 nothing is earned: no task points, no time bonus, and of the localization points
    at most the first tick's share (Q is the mean over the match's ticks, docs/rules.md). The
    score so far grows with the ticks and, at the last frame, is the referee's final score: on a
    race, on bac-line, whose waypoints are worth their legs' distance from the line, and on a
    goto task, whose arrival is a stop."""
    rep = load(replays[key])
    html = tmp_path / f"{key}.html"
    write_viewer(replays[key], html)
    page = _open(browser, html)
    page.evaluate("window.viewer.seek(0)")
    scores = page.locator("#now tr").all_inner_texts()[1:]
    for slot, robot in enumerate(rep.result["robots"]):
        assert robot["localization"]["quality"] > 0, "every robot of the test match reports estimates"
        first_tick = 25.0 / robot["localization"]["ticks"]  # the most one tick's estimate earns
        times = (0, 1, 3, rep.duration)
        at = [page.evaluate(f"window.viewer.scenes.standings.score({slot}, {t})") for t in times]
        assert 0 <= at[0] <= first_tick, at
        assert scores[slot].split("\t")[-1] == f"{at[0]:.1f}"
        earned = [
            a + sum(f["penalty"] for f in rep.fouls if f["r"] == slot and f["time"] <= t) for a, t in zip(at, times)
        ]
        assert earned[0] < earned[1] < earned[2] <= earned[3], earned  # points accrue as the match goes
        assert at[3] == pytest.approx(robot["score"]["total"], abs=0.01), (at, robot["score"])
        hud = page.evaluate("window.viewer.scenes.at(0).hud")[1 + slot]
        nothing = "not arrived" if key == "goto" else "0/"
        assert f"score {at[0]:6.1f}   {nothing}" in hud, hud  # no waypoint yet, no arrival
        task = robot["task"]
        assert task["finished"] is not None or key == "race"
        if task["finished"] is not None:  # just before and at the finish, the HUD says what was done
            line = "window.viewer.scenes.standings.line({}, 't', {})"
            before, after = (page.evaluate(line.format(slot, task["finished"] + d)) for d in (-0.05, 0))
            standings = Scenes(rep).standings  # pygame's HUD says the same
            assert [before, after] == [standings.line(slot, "t", task["finished"] + d) for d in (-0.05, 0)]
            if key == "goto":
                assert "not arrived" in before and f"arrived, {robot['score']['task']:.0f} %" in after, (before, after)
            else:
                assert f"{task['total'] - 1}/{task['total']} waypoints" in before and f"{task['total']}/" in after
    # the same in the HUD pygame draws (referee/media/standings.py)
    assert page.evaluate("window.viewer.scenes.at(0).hud") == list(Scenes(rep).at(0).hud)
    assert page.errors == [] and page.remote == []


@pytest.mark.parametrize("key, t", [("race", 3.0), ("vannoy", 2.0), ("simi", 1.5), ("osentoski", 1.5)])
def test_browser_frame_matches_the_pygame_frame(replays, browser, tmp_path, key, t):
    """The canvas at time t and arena/draw.py's frame of the same size and time, compared.

    Measured (Chromium 156, pygame-ce 2.5.8): mean absolute difference per channel at most 0.66
    on the field and 1.6 over the whole frame (the four-robot race); most of it is text
    (FreeType in pygame, Skia in Chromium, same font) and anti-aliased edges (the canvas smooths,
    pygame does not). The bounds sit between that and what a real error gives: the same page
    against pygame's frame 0.1 s later (robots 1-2 cm on, other beams) differs by 2.5 on the field.
    """
    html = tmp_path / f"{key}.html"
    write_viewer(replays[key], html)
    page = _open(browser, html)
    page.evaluate(f"window.viewer.seek({t})")
    web = _canvas(page)
    ref, painter, scenes = _pygame(replays[key], t)
    assert web.shape == ref.shape
    for when in (
        t,
        scenes.duration,
    ):  # the HUD's text, as referee/media/render.py writes it (the final scores at the end)
        assert page.evaluate(f"window.viewer.scenes.at({when}).hud") == list(scenes.at(when).hud)
    diff = np.abs(web - ref)
    field, whole = diff[:, painter.hud_height :].mean(), diff.mean()
    print(f"{key} t={t}: mean abs difference {field:.3f} on the field, {whole:.3f} over the frame")
    assert field < 1.5 and whole < 2.5

    if key == "race":  # the bound tells a wrong frame from the right one (here the robots move)
        later, _, _ = _pygame(replays[key], t + 0.1)
        wrong = np.abs(web - later)[:, painter.hud_height :].mean()
        print(f"{key}: against pygame's frame 0.1 s later, {wrong:.3f} on the field")
        assert wrong > 1.5

    # robots where the frame says, in both pictures, within 2 px
    frame = scenes.rep.frames[round(t * scenes.rate)][1]
    for slot, (x, y, _) in enumerate(frame):
        centre = painter.to_screen(x, y)
        radius = 0.45 * scenes.level.robots[slot].model.width * painter.scale  # inside the body
        a, b = _centroid(web, centre, radius, color(slot)), _centroid(ref, centre, radius, color(slot))
        assert math.dist(a, b) <= 2 and math.dist(a, centre) <= 2, (slot, a, b, centre)
    kind = scenes.level.beacons.kind
    r = max(5, round(scenes.level.beacons.radius * painter.scale))
    for beacon in scenes.level.beacons.items:
        centre = painter.to_screen(beacon.x, beacon.y)
        a, b = _centroid(web, centre, 2 * r, BEACON[kind]), _centroid(ref, centre, 2 * r, BEACON[kind])
        assert math.dist(a, b) <= 2, (beacon.id, a, b)
        for img in (web, ref):  # each beacon's name legible in both pictures, wherever it stands
            _legible_label(img, centre, painter.hud_height, beacon.id)
    assert page.errors == [] and page.remote == []


def _luminance(rgb) -> float:
    """WCAG 2's relative luminance of an sRGB colour (0..255 per channel)."""
    c = np.asarray(rgb, dtype=float) / 255
    c = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    return float(c @ [0.2126, 0.7152, 0.0722])


def _legible_label(img: np.ndarray, centre: tuple[int, int], hud: int, name: str) -> None:
    """Near a beacon (above it, either side), a white plate with dark letters on it: WCAG's
    enhanced contrast for text (7:1) between the letters and the plate, letters at least 10 px
    tall, the plate whole inside the frame and below the HUD."""
    x0, y0 = max(0, centre[0] - 60), max(hud + 1, centre[1] - 60)  # below the HUD (its timeline's knob is white)
    window = img[x0 : centre[0] + 60, y0 : centre[1] + 10]
    white = np.all(window >= 245, axis=2)
    assert white.sum() >= 30, f"beacon {name}: no label plate near {centre}"
    xs, ys = np.nonzero(white)
    plate = window[xs.min() : xs.max() + 1, ys.min() : ys.max() + 1]
    # its dark border inside the window on every side: the plate is whole, not cut by the HUD or the frame's edge
    top, bottom = y0 + ys.min(), y0 + ys.max()
    assert top > y0 and bottom < img.shape[1] - 1 and x0 + xs.min() > 0 and x0 + xs.max() < img.shape[0] - 1, name
    lum = np.apply_along_axis(_luminance, 2, plate)
    ink = lum < 0.2  # the letters' dark pixels
    rows = np.nonzero(ink.any(axis=0))[0]
    assert ink.sum() >= 10 and rows.max() - rows.min() + 1 >= 10, f"beacon {name}: letters too small"
    contrast = (lum.max() + 0.05) / (lum[ink].min() + 0.05)
    assert contrast >= 7, f"beacon {name}: contrast {contrast:.1f}"


def test_other_replays_open_by_picker_and_drop(replays, browser, tmp_path):
    html = tmp_path / "race.html"
    write_viewer(replays["race"], html)
    page = _open(browser, html)

    page.set_input_files("#file", str(replays["vannoy"]))  # a level this page does not embed: its hash differs
    page.wait_for_function("window.viewer.error !== null", timeout=WAIT_MS)
    assert "is not one this page knows" in page.evaluate("window.viewer.error")
    assert "laserarena render" in page.inner_text("#message")

    cut = tmp_path / "cut.replay"
    cut.write_bytes(replays["race"].read_bytes()[:3000])
    page.set_input_files("#file", str(cut))
    page.wait_for_function("window.viewer.error && window.viewer.error.startsWith('cut.replay')", timeout=WAIT_MS)
    assert "truncated or damaged" in page.evaluate("window.viewer.error")

    # a header with fields this page does not know (a later writer's) is read all the same
    lines = gzip.decompress(replays["race"].read_bytes()).decode().splitlines(keepends=True)
    header = json.loads(lines[0])
    header["organizer_note"] = {"heat": 7}
    newer = tmp_path / "newer.replay"
    newer.write_bytes(gzip.compress((json.dumps(header) + "\n" + "".join(lines[1:])).encode()))
    page.set_input_files("#file", str(newer))
    page.wait_for_function("window.viewer.name === 'newer.replay'", timeout=WAIT_MS)
    assert page.evaluate("window.viewer.error") is None

    # frames that lack a robot of the level: refused with a message, the replay shown before stays
    short = [
        json.dumps({**r, "p": r["p"][:1]}) + "\n" if r.get("k") == "f" else json.dumps(r) + "\n"
        for r in map(json.loads, lines[1:])
    ]
    (tmp_path / "short.replay").write_bytes(gzip.compress((lines[0] + "".join(short)).encode()))
    page.set_input_files("#file", str(tmp_path / "short.replay"))
    page.wait_for_function("window.viewer.error !== null", timeout=WAIT_MS)
    assert page.evaluate("window.viewer.error").startswith("short.replay: a damaged replay")
    assert page.evaluate("window.viewer.name") == "newer.replay"

    # drag and drop of the race again, under another name: it plays
    data = base64.b64encode(replays["race"].read_bytes()).decode()
    page.evaluate(
        """data => {
        const bytes = Uint8Array.from(atob(data), c => c.charCodeAt(0));
        const dt = new DataTransfer();
        dt.items.add(new File([bytes], 'again.replay'));
        document.dispatchEvent(new DragEvent('drop', {dataTransfer: dt, bubbles: true, cancelable: true}));
    }""",
        data,
    )
    page.wait_for_function("window.viewer.name === 'again.replay' && window.viewer.error === null", timeout=WAIT_MS)
    page.evaluate("window.viewer.seek(1.0)")
    assert page.evaluate("window.viewer.time") == 1.0
    assert page.errors == [] and page.remote == []


def test_a_built_in_level_replay_opens_in_any_page(browser, tmp_path):
    """Pages embed every built-in level, so a replay of one opens in a page made for another."""
    replay = tmp_path / "mini.replay"
    lv = parse_level(MINI_LEVEL.replace("time_limit: 4", "time_limit: 1").encode(), "mini.yaml")
    play_match(lv, [resolve("ref:dead-reckoning")], replay=replay, isolate=False)
    html = tmp_path / "mini.html"
    write_viewer(replay, html)  # embeds mini (its own level) and the built-in levels
    page = _open(browser, html)
    assert page.evaluate("window.viewer.error") is None
    builtin = tmp_path / "simi.replay"  # the built-in level file as shipped
    play_match(
        parse_level(levels.path("simi").read_bytes(), "simi.yaml"), [resolve("ref:idle")], replay=builtin, isolate=False
    )
    page.set_input_files("#file", str(builtin))
    page.wait_for_function("window.viewer.name === 'simi.replay'", timeout=WAIT_MS)
    assert page.evaluate("window.viewer.error") is None
    assert page.evaluate("window.viewer.duration") == pytest.approx(load(builtin).duration)
    assert page.errors == [] and page.remote == []


def test_page_needs_no_network_and_bad_input_is_one_line(replays, tmp_path):
    html = tmp_path / "page.html"
    proc = run_cli("render", str(replays["simi"]), "--out", str(html))  # the format from the extension
    assert proc.returncode == 0, proc.stderr
    text = html.read_text()
    assert not re.search(r"(src|href)\s*=\s*[\"']?(https?:)?//", text)  # nothing fetched from anywhere
    assert "DecompressionStream" in text and base64.b64encode(replays["simi"].read_bytes()[:30]).decode()[:40] in text
    cut = tmp_path / "cut.replay"
    cut.write_bytes(replays["simi"].read_bytes()[: len(replays["simi"].read_bytes()) // 2])
    for args, words in (
        (["render", str(cut), "--html", str(tmp_path / "x.html")], "truncated"),
        (["render", str(replays["simi"]), "--html", str(tmp_path / "no" / "x.html")], "does not exist"),
        (["render", str(replays["simi"])], "--html"),
    ):
        proc = run_cli(*args)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, (args, proc.stderr)
        assert words in proc.stderr and "Traceback" not in proc.stderr


def test_names_that_would_end_the_script_keep_the_page_working(browser, tmp_path):
    """A level, team and replay named with `</script>` and `<!--<script>` (which would end the
    page's data element or swallow the script after it) leave the page playing and the names intact."""
    bad = '</script><!--<script>&"x'
    bot = tmp_path / "bot<!--<script>.py"
    bot.write_text("from robots.controllers.dead_reckoning import DeadReckoning as Bot\n")
    level = parse_level(MINI_LEVEL.replace("name: mini", f"name: {json.dumps(bad)}").encode(), "mini.yaml")
    replay = tmp_path / "r<!--<script>.replay"
    play_match(level, [resolve(str(bot))], replay=replay, isolate=False)
    html = tmp_path / "page.html"
    write_viewer(replay, html)
    data = html.read_text().split('id="laserarena-data">', 1)[1].split("</script>", 1)[0]
    assert not set("<>&") & set(data)  # nothing in the data element the HTML tokenizer reads
    page = _open(browser, html)
    assert page.evaluate("window.viewer.error") is None and page.errors == []
    assert page.evaluate("JSON.parse(document.getElementById('laserarena-data').textContent).name") == replay.name
    assert page.title() == f"LaserArena replay — {replay.name}"
    levels_named = page.evaluate(
        "Object.values(JSON.parse(document.getElementById('laserarena-data').textContent).levels).map(l => l.name)"
    )
    assert bad in levels_named
