"""The catalog's ids and what ``make`` refuses: unknown ids, action types a game does not offer,
continuous actions out of range, a person's controls of a continuous variant. PettingZoo's API
tests, determinism, the headless picture, the state, a person's controls and the replay scene of
every id are checks of ``arena_league.envs.check``, run over the catalog in
``test_envs_conformance.py``."""

from __future__ import annotations

import numpy as np
import pytest

from arena_league.envs import game_spec, list_games, make, make_aec

GAMES = list_games()


def test_catalog_has_the_first_four_games_in_team_layouts():
    names = {g.split("-")[0] for g in GAMES}
    assert {"Crossroads", "Soccer", "GoBang", "Snake"} <= names
    for game in ("Crossroads", "Soccer"):
        assert f"{game}-2T1P-v1" in GAMES and f"{game}-2T2P-v1" in GAMES
    assert "Crossroads-2T4P-v1" in GAMES


def test_unknown_game_id_lists_valid_ids():
    with pytest.raises(ValueError) as err:
        make("Crossroad-2T2P-v1")
    assert "unknown game id 'Crossroad-2T2P-v1'" in str(err.value) and "Crossroads-2T2P-v1" in str(err.value)
    with pytest.raises(ValueError, match="Soccer is offered as: Soccer-2T1P-v1"):
        make("Soccer-5T5P-v1")
    with pytest.raises(ValueError, match=r"ids follow '<Game>-<x>T<y>P-v<N>'"):
        make("soccer")


def test_action_type_and_turn_based_errors():
    with pytest.raises(ValueError, match="GoBang-2T1P-v1 has no continuous action variant; valid: 'discrete'"):
        make("GoBang-2T1P-v1", action_type="continuous")
    with pytest.raises(ValueError, match="unknown action_type 'analog'"):
        make("Crossroads-2T2P-v1", action_type="analog")
    with pytest.raises(ValueError, match="no native AEC env"):
        make_aec("Crossroads-2T2P-v1")


@pytest.mark.parametrize("game_id", [g for g in GAMES if "continuous" in game_spec(g).rules.action_types][:2])
def test_continuous_actions_out_of_range_or_wrong_shape(game_id):
    env = make(game_id, action_type="continuous")
    env.reset(seed=0)
    dim = env.rules.act_dim
    good = {a: np.zeros(dim, np.float32) for a in env.agents}
    with pytest.raises(ValueError, match="out of range; every component must be finite and within"):
        env.step({**good, "player_0": np.full(dim, 1.5, np.float32)})
    with pytest.raises(ValueError, match=f"continuous actions are {dim} floats"):
        env.step({**good, "player_1": np.zeros(dim + 1, np.float32)})
    with pytest.raises(ValueError, match="not NaN|finite"):
        env.step({**good, "player_0": np.full(dim, np.nan, np.float32)})
    for values in ([0.5] + [np.nan] * (dim - 1), [np.nan] + [0.5] * (dim - 1), [0.1] * (dim - 1) + [-np.inf]):
        # NaN anywhere among cells in range (where min and max may pass over it), or an infinity
        with pytest.raises(ValueError, match="out of range; every component must be finite and within"):
            env.step({**good, "player_1": np.array(values, np.float32)})


@pytest.mark.parametrize("game_id", [g for g in GAMES if "continuous" in game_spec(g).rules.action_types
                                     and "discrete" in game_spec(g).rules.action_types])
def test_the_default_controls_ask_for_the_discrete_variant(game_id):
    env = make(game_id, action_type="continuous")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action_type='discrete'"):
        env.rules.human_controls(0)
