"""JSON schemas of the replay channels, and Foxglove's ``foxglove.SceneUpdate``.

Replays are MCAP files (https://mcap.dev) with ``json`` message encoding and ``jsonschema`` schemas,
so Foxglove Studio opens them and plots any field. The scene channel uses Foxglove's well-known
schema name ``foxglove.SceneUpdate`` (the JSON form of Foxglove's scene messages: entities made of
cubes, spheres, cylinders, arrows, lines and texts, each with a pose, size and RGBA colour in
[0, 1]), which the 3D panel draws. Its schema below is written out from Foxglove's published field
list; fields the scene adapters never use (models, triangle lists) are declared loosely.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CHANNEL_SCHEMAS", "SCENE_SCHEMA_NAME", "TOPICS", "scene_update_schema"]

SCENE_SCHEMA_NAME = "foxglove.SceneUpdate"

#: Topic of each channel of a replay.
TOPICS = {
    "observations": "/observations",
    "actions": "/actions",
    "rewards": "/rewards",
    "events": "/events",
    "scene": "/scene",
    "match": "/match",
    "result": "/result",
}


def _number_array(description: str, depth: int = 1) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "number"}
    for _ in range(depth):
        schema = {"type": "array", "items": schema}
    schema["description"] = description
    return schema


_STEP = {"type": "integer", "minimum": 0,
         "description": "env steps taken when this message holds (0: just after reset)"}

#: Schemas of the per-step channels, keyed by channel name (see :data:`TOPICS`).
CHANNEL_SCHEMAS: dict[str, dict[str, Any]] = {
    "observations": {
        "title": "arena_league.Observations",
        "description": "Every seat's flattened observation at a step (float32[n_agents, obs_dim])",
        "type": "object",
        "properties": {"step": _STEP, "obs": _number_array("one row per seat", depth=2)},
        "required": ["step", "obs"],
    },
    "actions": {
        "title": "arena_league.Actions",
        "description": "The actions every seat sent at a step (discrete: one integer per seat; "
                       "continuous: one vector per seat); the env moves from step to step + 1",
        "type": "object",
        "properties": {"step": _STEP, "actions": {"type": "array", "description": "one entry per seat"},
                       "acting": {"type": "array", "items": {"type": "boolean"},
                                  "description": "seats whose action the rules took (others are fillers)"}},
        "required": ["step", "actions"],
    },
    "rewards": {
        "title": "arena_league.Rewards",
        "description": "Every seat's social-tree reward for the step that ended at `step`",
        "type": "object",
        "properties": {"step": _STEP, "rewards": _number_array("one reward per seat")},
        "required": ["step", "rewards"],
    },
    "events": {
        "title": "arena_league.Event",
        "description": "One event reported by the game rules during the step that ended at `step`",
        "type": "object",
        "properties": {"step": _STEP, "kind": {"type": "string"},
                       "event": {"type": "object", "description": "the rules' event record"}},
        "required": ["step", "kind", "event"],
    },
    "match": {
        "title": "arena_league.Match",
        "description": "What was played: game, seeds, seats and env options (enough to replay it)",
        "type": "object",
        "properties": {
            "match_id": {"type": "integer"}, "game_id": {"type": "string"},
            "league_seed": {"type": "integer"}, "seed": {"type": "integer"},
            "seats": {"type": "array", "items": {"type": "string"}},
            "teams": {"type": "array", "items": {"type": "integer"}},
            "env_kwargs": {"type": "object"}, "format_version": {"type": "integer"},
            "half": {"type": "integer", "enum": [0, 1], "description": "which match of a pair (absent: unpaired)"},
        },
        "required": ["match_id", "game_id", "league_seed", "seed", "seats", "teams", "env_kwargs"],
    },
    "result": {
        "title": "arena_league.MatchResult",
        "description": "The match result, seat by seat",
        "type": "object",
        "properties": {
            "steps": {"type": "integer"}, "scores": _number_array("team score of each seat"),
            "outcomes": {"type": "array", "items": {"type": "string", "enum": ["win", "loss", "draw"]}},
            "positions": {"type": ["array", "null"], "items": {"type": "integer"}},
            "points": _number_array("a half of a pair: what each seat's team scored toward the pair"),
        },
        "required": ["steps", "scores", "outcomes"],
    },
}


def _vector3(description: str) -> dict[str, Any]:
    return {"title": "foxglove.Vector3", "description": description, "type": "object",
            "properties": {axis: {"type": "number"} for axis in "xyz"}, "required": list("xyz")}


def _time(title: str, description: str) -> dict[str, Any]:
    return {"type": "object", "title": title, "description": description,
            "properties": {"sec": {"type": "integer", "minimum": 0},
                           "nsec": {"type": "integer", "minimum": 0, "maximum": 999_999_999}}}


def _pose(description: str) -> dict[str, Any]:
    quaternion = {"title": "foxglove.Quaternion", "type": "object",
                  "properties": {axis: {"type": "number"} for axis in "xyzw"}, "required": list("xyzw")}
    return {"title": "foxglove.Pose", "description": description, "type": "object",
            "properties": {"position": _vector3("position"), "orientation": quaternion},
            "required": ["position", "orientation"]}


def _color() -> dict[str, Any]:
    return {"title": "foxglove.Color", "type": "object",
            "properties": {c: {"type": "number", "minimum": 0, "maximum": 1} for c in "rgba"},
            "required": list("rgba")}


def _primitive(title: str, extra: dict[str, Any], required: list[str]) -> dict[str, Any]:
    return {"type": "array", "items": {"title": title, "type": "object", "properties": extra,
                                       "required": required}}


def scene_update_schema() -> dict[str, Any]:
    """The JSON schema of ``foxglove.SceneUpdate`` messages."""
    pose, color = _pose("pose of the primitive"), _color()
    entity = {
        "title": "foxglove.SceneEntity",
        "type": "object",
        "properties": {
            "timestamp": _time("time", "Timestamp of the entity"),
            "frame_id": {"type": "string"},
            "id": {"type": "string", "description": "replaces any prior entity with the same id"},
            "lifetime": _time("duration", "zero: visible until replaced or deleted"),
            "frame_locked": {"type": "boolean"},
            "metadata": _primitive("foxglove.KeyValuePair", {"key": {"type": "string"},
                                                             "value": {"type": "string"}}, ["key", "value"]),
            "arrows": _primitive("foxglove.ArrowPrimitive", {
                "pose": pose, "shaft_length": {"type": "number"}, "shaft_diameter": {"type": "number"},
                "head_length": {"type": "number"}, "head_diameter": {"type": "number"}, "color": color},
                ["pose", "shaft_length", "shaft_diameter", "head_length", "head_diameter", "color"]),
            "cubes": _primitive("foxglove.CubePrimitive", {"pose": pose, "size": _vector3("size"), "color": color},
                                ["pose", "size", "color"]),
            "spheres": _primitive("foxglove.SpherePrimitive", {"pose": pose, "size": _vector3("diameters"),
                                                               "color": color}, ["pose", "size", "color"]),
            "cylinders": _primitive("foxglove.CylinderPrimitive", {
                "pose": pose, "size": _vector3("size"), "bottom_scale": {"type": "number"},
                "top_scale": {"type": "number"}, "color": color},
                ["pose", "size", "bottom_scale", "top_scale", "color"]),
            "lines": _primitive("foxglove.LinePrimitive", {
                "type": {"title": "foxglove.LineType", "enum": [0, 1, 2],
                         "description": "0 LINE_STRIP, 1 LINE_LOOP, 2 LINE_LIST"},
                "pose": pose, "thickness": {"type": "number"}, "scale_invariant": {"type": "boolean"},
                "points": {"type": "array", "items": {"title": "foxglove.Point3", "type": "object",
                                                      "properties": {a: {"type": "number"} for a in "xyz"},
                                                      "required": list("xyz")}},
                "color": color, "colors": {"type": "array", "items": color},
                "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}}},
                ["type", "pose", "thickness", "scale_invariant", "points", "color", "colors", "indices"]),
            "triangles": {"type": "array", "items": {"title": "foxglove.TriangleListPrimitive", "type": "object"}},
            "texts": _primitive("foxglove.TextPrimitive", {
                "pose": pose, "billboard": {"type": "boolean"}, "font_size": {"type": "number"},
                "scale_invariant": {"type": "boolean"}, "color": color, "text": {"type": "string"}},
                ["pose", "billboard", "font_size", "scale_invariant", "color", "text"]),
            "models": {"type": "array", "items": {"title": "foxglove.ModelPrimitive", "type": "object"}},
        },
        "required": ["timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata", "arrows", "cubes",
                     "spheres", "cylinders", "lines", "triangles", "texts", "models"],
    }
    deletion = {
        "title": "foxglove.SceneEntityDeletion",
        "type": "object",
        "properties": {"timestamp": _time("time", "entities older than this are deleted"),
                       "type": {"title": "foxglove.SceneEntityDeletionType", "enum": [0, 1],
                                "description": "0 MATCHING_ID, 1 ALL"},
                       "id": {"type": "string"}},
        "required": ["timestamp", "type", "id"],
    }
    return {"title": SCENE_SCHEMA_NAME, "description": "An update to the entities displayed in a 3D scene",
            "type": "object",
            "properties": {"deletions": {"type": "array", "items": deletion},
                           "entities": {"type": "array", "items": entity}},
            "required": ["deletions", "entities"]}
