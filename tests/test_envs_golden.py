"""Every game plays its seeded episodes exactly as it did before the 2D games moved onto one engine.

The digests in ``tests/data/golden_trajectories.json`` were recorded by ``tests/golden_trajectories.py``
at the commit before that move; a difference in any observation, reward, state, event or result
of any step changes an episode's digest.
"""

from __future__ import annotations

import json

import pytest
from golden_trajectories import GOLDEN, configurations, game_digests

RECORDED = json.loads(GOLDEN.read_text())


def test_every_game_and_action_type_was_recorded():
    assert sorted(f"{game_id} {action_type}" for game_id, action_type in configurations()) == sorted(RECORDED)


@pytest.mark.parametrize(("game_id", "action_type"), configurations())
def test_seeded_episodes_replay_bit_for_bit(game_id, action_type):
    digests = game_digests(game_id, action_type)
    differ = [seed for seed, (new, old) in enumerate(zip(digests, RECORDED[f"{game_id} {action_type}"])) if new != old]
    assert not differ, f"{game_id} {action_type}: episodes of seeds {differ} differ from the recorded ones"
