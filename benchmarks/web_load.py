"""The web service under load: leaderboard latency for a league of 1,000 agents, and 50 concurrent
readers while 5 uploads are validated. Prints one JSON document.

The league: GoBang-2T1P-v1 with its shipped 100-member base population imported, and 900 more
agents placed against it (placements and matches written straight to the registry, with seeded
random ratings and outcomes: this measures serving, not ranking). ``arena-league serve`` runs in a
subprocess on a free loopback port with one job worker; the clients are httpx, on this machine.

Figures, side by side:

* ``board_compute_ms``: computing the board in-process, what every request would cost without the
  cache (the peer: an uncached leaderboard endpoint);
* ``cold_ms``: the first request (the server computes and caches the board);
* ``warm``: one client's sequential requests to the cached board (median, p95);
* ``load``: ``--clients`` clients reading boards as fast as they can for ``--seconds`` (at most
  ``--requests`` in all) while ``--uploads`` agents are uploaded and validated by the worker;
  errors counted (anything but 200 / 202), latency median and p95, uploads validated.

    python benchmarks/web_load.py [--agents 1000] [--clients 50] [--uploads 5] [--seconds 20] [--requests 4000]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from web_helpers import running_server

from arena_league import registry as reg
from arena_league.league import create_token, import_population, leaderboard, open_home, shipped_population
from arena_league.policies import Architecture, init_parameters, save_arena_policy

GAME = "GoBang-2T1P-v1"


def build_league(home: Path, n_agents: int, seed: int = 0) -> dict:
    """The league of the module docstring; returns what it holds."""
    rng = np.random.default_rng(seed)
    started = time.perf_counter()
    with open_home(home) as league:
        base = import_population(league, shipped_population(GAME))
        with league.reading() as session:
            population = next(p for p in reg.list_populations(session, game_id=GAME) if p.frozen)
            members = [(m.agent.name, m.agent.id, (m.meta or {}).get("rating")) for m in population.members]
        entrants = n_agents - len(members)
        with league.transaction() as session:
            ids = [reg.create_agent(session, f"entrant-{i:04d}", GAME, "scripted", owner=f"owner-{i % 40}",
                                    status="active", metadata={"scripted": "random"}).id for i in range(entrants)]
        ratings = np.asarray([r for _, _, r in members], dtype=float)
        records = []
        match = 0
        for index, agent_id in enumerate(ids):
            rating = float(rng.normal(ratings.mean(), ratings.std()))
            opponents = rng.choice(len(members), size=10, replace=False)
            for k in opponents:
                win = rng.random() < 1 / (1 + 10 ** ((ratings[k] - rating) / 400))
                first = (agent_id, members[k][1]) if match % 2 == 0 else (members[k][1], agent_id)
                first_wins = win if match % 2 == 0 else not win
                records.append(reg.MatchRecord(f"load:{match}", match, [
                    reg.SeatResult(first[0], 0, float(first_wins), "win" if first_wins else "loss"),
                    reg.SeatResult(first[1], 1, float(not first_wins), "loss" if first_wins else "win")]))
                match += 1
            with league.transaction() as session:
                job = reg.enqueue(session, "rank", {"game_id": GAME, "agent": f"entrant-{index:04d}",
                                                    "base_label": base, "budget": 10, "seed": 0})
            claimed = reg.claim_job(league, "load-builder", job_id=job.id)
            rank = int(1 + (ratings > rating).sum())
            reg.complete_job(league, claimed, {
                "agent": f"entrant-{index:04d}", "game_id": GAME, "base": base, "base_size": len(members),
                "matches": 10, "rating": rating, "lower": rating - 120, "upper": rating + 120, "rank": rank,
                "rank_lower": max(1, rank - 5), "rank_upper": min(len(members) + 1, rank + 5),
                "percentile": float(100 * (ratings < rating).mean()), "percentile_lower": 0.0,
                "percentile_upper": 100.0, "level": 0.95, "job_id": job.id, "opponents": {}})
        with league.transaction() as session:
            for start in range(0, len(records), 2000):
                reg.record_matches(session, GAME, records[start: start + 2000])
        token = create_token(league, "uploader")["token"]
        compute = []
        for _ in range(3):
            tick = time.perf_counter()
            board = leaderboard(league, GAME, save=False, import_shipped=False)
            compute.append(time.perf_counter() - tick)
    return {"agents": len(members) + entrants, "matches": match, "base": base, "token": token,
            "rows": len(board.rows), "board_compute_ms": round(1e3 * min(compute), 1),
            "build_seconds": round(time.perf_counter() - started, 1)}


def timed_get(client: httpx.Client, path: str) -> float:
    tick = time.perf_counter()
    response = client.get(path)
    response.raise_for_status()
    return 1e3 * (time.perf_counter() - tick)


def summary(latencies: list[float]) -> dict:
    ordered = sorted(latencies)
    return {"requests": len(ordered), "median_ms": round(statistics.median(ordered), 1),
            "p95_ms": round(ordered[int(0.95 * (len(ordered) - 1))], 1), "max_ms": round(ordered[-1], 1)}


async def load(url: str, token: str, folder: Path, clients: int, uploads: int, seconds: float, limit: int) -> dict:
    path = f"/api/games/{GAME}/leaderboard"
    latencies: list[float] = []
    statuses: dict[int, int] = {}
    deadline = time.monotonic() + seconds

    async def reader(client: httpx.AsyncClient) -> None:
        while time.monotonic() < deadline and len(latencies) < limit:
            tick = time.perf_counter()
            response = await client.get(path)
            latencies.append(1e3 * (time.perf_counter() - tick))
            statuses[response.status_code] = statuses.get(response.status_code, 0) + 1

    async def uploader(client: httpx.AsyncClient, index: int) -> float:
        spec_folder = folder / f"upload-{index}"
        arch = Architecture("mlp", obs_dim=455, action_type="discrete", n_actions=225, hidden=(16,))
        save_arena_policy(spec_folder, arch, init_parameters(arch, 100 + index), GAME, name=f"up-{index}")
        tick = time.perf_counter()
        files = [("file", (n, (spec_folder / n).read_bytes())) for n in ("manifest.json", "weights.safetensors")]
        response = await client.post("/api/agents", data={"game": GAME, "name": f"load-upload-{index}"},
                                     files=files, headers={"Authorization": f"Bearer {token}"})
        statuses[response.status_code] = statuses.get(response.status_code, 0) + 1
        job = response.json()["job"]
        while True:
            state = (await client.get(f"/api/jobs/{job}")).json()
            if state["finished"]:
                assert state["state"] == "done" and state["result"]["status"] == "active", state
                return time.perf_counter() - tick
            await asyncio.sleep(0.2)

    limits = httpx.Limits(max_connections=clients + uploads + 2)
    async with httpx.AsyncClient(base_url=url, timeout=120, limits=limits) as client:
        started = time.perf_counter()
        results = await asyncio.gather(*[reader(client) for _ in range(clients)],
                                       *[uploader(client, i) for i in range(uploads)])
        elapsed = time.perf_counter() - started
    upload_seconds = [r for r in results if r is not None]
    errors = sum(n for status, n in statuses.items() if status not in (200, 202))
    return {"clients": clients, "uploads": uploads, "seconds": round(elapsed, 1), "statuses": statuses,
            "errors": errors, "requests_per_s": round(len(latencies) / elapsed, 1), **summary(latencies),
            "uploads_validated": len(upload_seconds),
            "upload_to_active_s": [round(s, 2) for s in upload_seconds]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--agents", type=int, default=1000)
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--uploads", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--requests", type=int, default=4000, help="leaderboard requests of the load, at most")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        home = Path(scratch) / "home"
        league = build_league(home, args.agents)
        with running_server(home, workers=1) as server, httpx.Client(base_url=server.url, timeout=120) as client:
            cold = timed_get(client, f"/api/games/{GAME}/leaderboard")
            warm = summary([timed_get(client, f"/api/games/{GAME}/leaderboard") for _ in range(200)])
            under_load = asyncio.run(load(server.url, league["token"], Path(scratch), args.clients, args.uploads,
                                          args.seconds, args.requests))
            after = summary([timed_get(client, f"/api/games/{GAME}/leaderboard") for _ in range(100)])
    report = {"benchmark": "web_load", "python": platform.python_version(), "machine": platform.machine(),
              "league": {k: v for k, v in league.items() if k != "token"}, "cold_ms": round(cold, 1),
              "warm": warm, "load": under_load, "after_load": after,
              "speedup_cached_vs_computed": round(league["board_compute_ms"] / warm["median_ms"], 1)}
    json.dump(report, sys.stdout, indent=2)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
