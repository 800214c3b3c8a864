"""The social tree: five basic multi-agent reward schemes (NL, IS, CP, CL, CC), their reward
function library, the tree that composes them, and their verification by sampling."""

from arena_league.envs.social.rewards import (
    REWARD_FUNCTIONS,
    SCHEMES,
    NodeView,
    RewardContext,
    RewardFunction,
    lookup_reward,
    register_grouped,
    register_reward,
    unregister_reward,
)
from arena_league.envs.social.tree import (
    SocialNode,
    SocialTree,
    TreeSpecError,
    load_tree_spec,
    team_groups,
    team_tree,
)

__all__ = [
    "REWARD_FUNCTIONS",
    "SCHEMES",
    "NodeView",
    "RewardContext",
    "RewardFunction",
    "SocialNode",
    "SocialTree",
    "TreeSpecError",
    "load_tree_spec",
    "lookup_reward",
    "register_grouped",
    "register_reward",
    "team_groups",
    "team_tree",
    "unregister_reward",
]
