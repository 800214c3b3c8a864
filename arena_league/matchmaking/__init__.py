"""The match engine: match specs and seeds, the batched lockstep runner, its backends (in-process,
process pool, Ray; :func:`join_ray` joins a Ray cluster) and opponent selection. Replays are recorded by a :class:`MatchRecording` the
caller passes in (``arena_league.replay.ReplayRecording``), so the engine writes no file format itself.

    from arena_league.matchmaking import AgentRef, play_matches, round_robin, specs_for_seatings

    agents = {name: AgentRef("scripted", name, "GoBang-2T1P-v1") for name in ("random", "heuristic")}
    seatings = round_robin(list(agents), matches_per_pair=10)
    specs = specs_for_seatings("GoBang-2T1P-v1", seatings, league_seed=7)
    results = play_matches(specs, agents, backend="process")
"""

from arena_league.matchmaking.agents import AGENT_KINDS, AgentRef, load_agents
from arena_league.matchmaking.backends import BACKENDS, play_chunk, play_matches
from arena_league.matchmaking.cluster import NODE_IP_VARIABLE, join_ray
from arena_league.matchmaking.runner import (
    LockstepRunner,
    MatchRecording,
    PolicyError,
    PolicyUnit,
    action_spec_of,
    policy_units,
)
from arena_league.matchmaking.selection import (
    LeastPlayedChooser,
    OpponentChooser,
    berger_round,
    pair_counts,
    play_adaptive,
    round_robin,
)
from arena_league.matchmaking.specs import (
    OUTCOMES,
    MatchResult,
    MatchSpec,
    match_seed,
    seat_rng,
    specs_for_seatings,
)

__all__ = [
    "AGENT_KINDS",
    "BACKENDS",
    "NODE_IP_VARIABLE",
    "OUTCOMES",
    "AgentRef",
    "LeastPlayedChooser",
    "LockstepRunner",
    "MatchRecording",
    "MatchResult",
    "MatchSpec",
    "OpponentChooser",
    "PolicyError",
    "PolicyUnit",
    "action_spec_of",
    "berger_round",
    "join_ray",
    "load_agents",
    "match_seed",
    "pair_counts",
    "play_adaptive",
    "play_chunk",
    "play_matches",
    "policy_units",
    "round_robin",
    "seat_rng",
    "specs_for_seatings",
]
