"""The play page's round trip: one step of play in the browser, over the WebSocket on loopback.
Prints one JSON document.

``arena-league serve`` runs in a subprocess on a free loopback port; a client (the ``websockets``
library, as a page would) plays GoBang-2T1P-v1 as a guest against the shipped base population,
clicking random empty cells. One *round trip* is a click sent until the frame that waits for the
next click (or the match's end) arrives: the person's stone, the opponent's reply (a policy
forward), both frames drawn and encoded, and the socket both ways. Side by side in the same run:

* ``browser``: the play page itself in Debian's Chromium (headless, driven by Playwright): a click
  on the canvas until the page has drawn the frame that waits for the next click (skipped where
  Chromium or Playwright is missing);
* ``websocket``: that round trip for a client with no page (median, p95, max over ``--moves`` moves);
* ``in_process``: the same moves played on :class:`~arena_league.league.live.LivePlay` directly,
  the server's own share of it (the peer: playing at a terminal, no socket, no browser);
* ``paced``: Snake-2T2P-v1, which the server steps by itself at 6 steps per second: the spacing of
  the frames the client receives (median and worst deviation from 1/6 s) and the delay from a key
  to the first frame after it.

    python benchmarks/web_play.py [--moves 200]
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from websockets.sync.client import connect

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from browser_helpers import CHROMIUM, chromium, to_screen
from web_helpers import running_server

from arena_league.league import LivePlay, open_home

GAME = "GoBang-2T1P-v1"
SIZE = 15


def summary(values: list[float]) -> dict:
    ordered = sorted(values)
    return {"moves": len(ordered), "median_ms": round(statistics.median(ordered), 2),
            "p95_ms": round(ordered[int(0.95 * (len(ordered) - 1))], 2), "max_ms": round(ordered[-1], 2)}


def occupied(shapes: list[dict]) -> set[int]:
    """The cells holding a stone in a GoBang frame (stones are circles on cell centres)."""
    cells = set()
    for shape in shapes:
        if shape["kind"] == "circle" and shape["r"] > 0.3:
            cells.add((SIZE - 1 - int(shape["y"])) * SIZE + int(shape["x"]))
    return cells


def pick(rng: np.random.Generator, taken: set[int]) -> list[float]:
    free = [c for c in range(SIZE * SIZE) if c not in taken]
    cell = int(free[rng.integers(len(free))])
    row, col = divmod(cell, SIZE)
    return [col + 0.5, SIZE - row - 0.5]


def over_socket(url: str, moves: int, seed: int) -> list[float]:
    rng = np.random.default_rng(seed)
    times: list[float] = []
    with connect(f"{url.replace('http', 'ws')}/ws/play/{GAME}?guest=bench", max_size=1 << 24) as socket:
        assert json.loads(socket.recv())["type"] == "hello"
        socket.send(json.dumps({"type": "next"}))
        taken: set[int] = set()
        waiting = False
        while len(times) < moves:
            if not waiting:  # read until the page would wait for a click
                message = json.loads(socket.recv())
                if message["type"] == "frame":
                    taken, waiting = occupied(message["shapes"]), message["waiting"]
                elif message["type"] == "end":
                    socket.send(json.dumps({"type": "next"}))
                continue
            tick = time.perf_counter()
            socket.send(json.dumps({"type": "act", "point": pick(rng, taken)}))
            while True:
                message = json.loads(socket.recv())
                if message["type"] == "frame":
                    taken = occupied(message["shapes"])
                    if message["waiting"]:
                        break
                elif message["type"] in ("end", "refused"):
                    break
            times.append(1e3 * (time.perf_counter() - tick))
            waiting = message["type"] == "frame" or message["type"] == "refused"
            if message["type"] == "end":
                socket.send(json.dumps({"type": "next"}))
    return times


_CLICK_AND_WAIT = """async ([x, y]) => {
  const root = document.getElementById('play');
  const step = root.dataset.step;
  const canvas = document.querySelector('[data-role="view"]');
  const started = performance.now();
  const done = new Promise((resolve) => {
    const observer = new MutationObserver(() => {
      if (root.dataset.state === 'ended' || (root.dataset.state === 'your-move' && root.dataset.step !== step)) {
        observer.disconnect();
        resolve(performance.now() - started);
      }
    });
    observer.observe(root, {attributes: true});
    setTimeout(() => { observer.disconnect(); resolve(null); }, 5000);
  });
  canvas.dispatchEvent(new MouseEvent('click', {clientX: x, clientY: y, bubbles: true}));
  return await done;
}"""


def in_browser(url: str, moves: int, seed: int) -> dict:
    """Clicks on the play page in Chromium, each timed from the click to the next frame drawn."""
    try:
        from playwright import sync_api
    except ImportError:
        return {"skipped": "Playwright is not installed"}
    if not CHROMIUM.exists():
        return {"skipped": f"no Chromium at {CHROMIUM}"}
    rng = np.random.default_rng(seed)
    times: list[float] = []
    taken: set[int] = set()

    def on_frame(payload: str | bytes) -> None:
        nonlocal taken
        message = json.loads(payload)
        if message.get("type") == "frame":
            taken = occupied(message["shapes"])

    with chromium(sync_api) as browser:
        page = browser.new_page(viewport={"width": 1280, "height": 1000})
        page.on("websocket", lambda socket: socket.on("framereceived", on_frame))
        page.goto(f"{url}/play/{GAME}")
        page.fill('[data-role="guest"]', "browser-bench")
        page.click('[data-role="start"]')
        while len(times) < moves:
            page.wait_for_function("() => ['your-move', 'ended'].includes(document.getElementById('play')"
                                   ".dataset.state)", timeout=60_000)
            if page.get_attribute("#play", "data-state") == "ended":
                page.click('[data-role="next"]')
                page.wait_for_function("() => document.getElementById('play').dataset.state !== 'ended'")
                continue
            elapsed = page.evaluate(_CLICK_AND_WAIT, list(to_screen(page, *pick(rng, taken))))
            if elapsed is not None:
                times.append(float(elapsed))
    return summary(times)


def in_process(home: Path, moves: int, seed: int) -> list[float]:
    rng = np.random.default_rng(seed)
    times: list[float] = []
    with open_home(home) as league:
        live = LivePlay(league, GAME, player="guest-bench2", owner="guest-bench2")
        messages = live.start()
        while len(times) < moves:
            frames = [m for m in messages if m["type"] == "frame"]
            if any(m["type"] == "end" for m in messages):
                messages = live.start()
                continue
            tick = time.perf_counter()
            messages = live.act({"type": "act", "point": pick(rng, occupied(frames[-1]["shapes"]))})
            times.append(1e3 * (time.perf_counter() - tick))
    return times


def paced(url: str, frames: int) -> dict:
    gaps: list[float] = []
    delays: list[float] = []
    with connect(f"{url.replace('http', 'ws')}/ws/play/Snake-2T2P-v1?guest=pacer", max_size=1 << 24) as socket:
        assert json.loads(socket.recv())["type"] == "hello"
        socket.send(json.dumps({"type": "next"}))
        last = None
        keys = ["a", "w", "d", "s"]
        while len(gaps) < frames:
            message = json.loads(socket.recv())
            if message["type"] == "end":
                socket.send(json.dumps({"type": "next"}))
                last = None
                continue
            if message["type"] != "frame":
                continue
            now = time.perf_counter()
            if last is not None:
                gaps.append(1e3 * (now - last))
            last = now
            if len(gaps) % 5 == 2:  # a key now and then: how long until the next frame
                sent = time.perf_counter()
                socket.send(json.dumps({"type": "act", "text": keys[len(gaps) % 4]}))
                while True:
                    message = json.loads(socket.recv())
                    if message["type"] in ("frame", "end"):
                        break
                delays.append(1e3 * (time.perf_counter() - sent))
                if message["type"] == "end":
                    socket.send(json.dumps({"type": "next"}))
                    last = None
                else:
                    gaps.append(1e3 * (time.perf_counter() - last))
                    last = time.perf_counter()
    period = 1e3 / 6.0
    return {"game": "Snake-2T2P-v1", "pace_per_s": 6.0, "frames": len(gaps),
            "gap_median_ms": round(statistics.median(gaps), 1),
            "gap_worst_deviation_ms": round(max(abs(g - period) for g in gaps), 1),
            "key_to_frame_median_ms": round(statistics.median(delays), 1),
            "key_to_frame_max_ms": round(max(delays), 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--moves", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        home = Path(folder) / "home"
        with running_server(home, workers=0) as server:
            warm = over_socket(server.url, 5, args.seed + 1)  # imports the base population, loads torch
            socket_times = over_socket(server.url, args.moves, args.seed)
            page = in_browser(server.url, args.moves, args.seed)
            pace = paced(server.url, 60)
        local = in_process(home, args.moves, args.seed)
    print(json.dumps({"game": GAME, "machine": {"python": platform.python_version(), "cpu": platform.processor()
                                                or platform.machine()},
                      "browser": page, "websocket": summary(socket_times), "in_process": summary(local),
                      "first_moves_ms": [round(t, 1) for t in warm], "paced": pace}, indent=2))


if __name__ == "__main__":
    main()
