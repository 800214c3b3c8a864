"""Pictures of robot scenes: a top-down projection drawn with numpy and Pillow (no display, no GL),
and MuJoCo's own renderer where an OpenGL context can be made (``MUJOCO_GL=egl``).

The top-down picture drops the vertical axis: each robot is drawn as its torso (a disc in its
team's colour, darker once it has fallen, with a tick along its forward axis) and its legs as
segments from the torso through hip and ankle to the foot tip, each box as its horizontal square,
and the floor markings (ring, lines, target discs) of the scene layout. Body poses come from
``MjData.xpos`` / ``xmat``, the same instant as the sensors (see ``envs.robots.scene``).

The replay scene (:func:`replay_scene`, every robot game's ``scene_entities``) shows the same in
3D: the floor of the picture's extent, the markings (``markings``: the ring as a loop, lines, target
discs), each box (``box/<b>``, a cube in its pose) and each robot (``agent/<seat>``: its torso as a
sphere in its team's colour, darker once fallen, its legs as lines from the torso through hip and
ankle to the foot tip, and an arrow along its forward axis).
"""

from __future__ import annotations

import os
from typing import Any

import mujoco
import numpy as np

from arena_league.envs.rendering import TEAM_COLOURS, Canvas
from arena_league.envs.robots.ant import ROBOTS
from arena_league.envs.robots.scene import Scene
from arena_league.envs.scene import Colour, arrow, colour_of, cube, disc, entity, lines, sphere, team_colour

FLOOR_COLOUR = (90, 115, 90)
MARKING_COLOUR = (240, 240, 240)
TARGET_COLOUR = (240, 215, 80)


def _shade(colour: tuple[int, int, int], amount: float) -> tuple[int, int, int]:
    return tuple(round(c * (1 - amount) + 255 * amount) for c in colour)  # type: ignore[return-value]


def topdown_picture(scene: Scene, data: mujoco.MjData, extent: tuple[float, float, float, float],
                    size: int = 400) -> np.ndarray:
    """A ``uint8[H, W, 3]`` picture of the scene from above, of the world box ``extent``."""
    x0, x1, y0, y1 = extent
    canvas = Canvas(x0, x1, y0, y1, size=size, background=FLOOR_COLOUR)
    width = max(1, round(0.04 * canvas.scale))
    for kind, numbers in scene.layout.markings:
        if kind == "ring":
            canvas.draw.ellipse([*canvas.px(-numbers[0], numbers[0]), *canvas.px(numbers[0], -numbers[0])],
                                outline=MARKING_COLOUR, width=width)
        elif kind == "line":
            canvas.line(*numbers, fill=MARKING_COLOUR, width_px=width)
        elif kind == "disc":
            canvas.circle(*numbers, fill=TARGET_COLOUR, outline=MARKING_COLOUR)
    xpos = data.xpos
    xmat = data.xmat.reshape(-1, 3, 3)
    half = scene.layout.box_half
    corners = half * np.array([(1, 1, 0), (-1, 1, 0), (-1, -1, 0), (1, -1, 0)], dtype=np.float64)
    for b, team in zip(scene.box_body, scene.layout.box_teams):
        square = xpos[b] + corners @ xmat[b].T
        canvas.draw.polygon([canvas.px(x, y) for x, y, _ in square], fill=_shade(TEAM_COLOURS[team], 0.45),
                            outline=(40, 40, 40))
    leg_px = max(2, round(0.1 * canvas.scale))
    for i, (kind, team) in enumerate(zip(scene.layout.robots, scene.layout.teams)):
        torso_radius = ROBOTS[kind][1].torso_radius
        colour = TEAM_COLOURS[team % len(TEAM_COLOURS)]
        torso = xpos[scene.torso_body[i]]
        leg_colour = tuple(int(c * 0.7) for c in colour)
        for k in range(scene.hip_body.shape[1]):
            hip = xpos[scene.hip_body[i, k]]
            shin = xpos[scene.shin_body[i, k]]
            foot = shin + xmat[scene.shin_body[i, k]] @ scene.foot_vector[k]
            points = [canvas.px(p[0], p[1]) for p in (torso, hip, shin, foot)]
            canvas.draw.line(points, fill=leg_colour, width=leg_px)
        up_z = xmat[scene.torso_body[i]][2, 2]
        canvas.circle(torso[0], torso[1], torso_radius, fill=colour if up_z >= 0 else leg_colour,
                      outline=(20, 20, 20))
        forward = xmat[scene.torso_body[i]][:, 0]
        canvas.line(torso[0], torso[1], torso[0] + 0.3 * forward[0], torso[1] + 0.3 * forward[1],
                    fill=(250, 250, 250), width_px=max(1, leg_px // 2))
    return canvas.array()


def replay_scene(scene: Scene, data: mujoco.MjData, extent: tuple[float, float, float, float],
                 timestamp_ns: int) -> list[dict[str, Any]]:
    """The scene's ``foxglove.SceneEntity`` dicts now (see the module docstring); the floor
    covers the world box ``extent`` of the top-down picture."""
    ts = timestamp_ns
    x0, x1, y0, y1 = extent
    floor, marking, target = colour_of(FLOOR_COLOUR), colour_of(MARKING_COLOUR), colour_of(TARGET_COLOUR)
    loops, segments, discs = [], [], []
    for kind, numbers in scene.layout.markings:
        if kind == "ring":
            angles = np.linspace(0.0, 2.0 * np.pi, 64, endpoint=False)
            loops.append(lines([(numbers[0] * np.cos(a), numbers[0] * np.sin(a), 0.005) for a in angles], marking,
                               0.04, kind="loop"))
        elif kind == "line":
            segments += [(numbers[0], numbers[1], 0.005), (numbers[2], numbers[3], 0.005)]
        elif kind == "disc":
            discs.append(disc(numbers[0], numbers[1], 2.0 * numbers[2], target, height=0.01))
    if segments:
        loops.append(lines(segments, marking, 0.04))
    out = [entity("floor", ts, cubes=[cube((x0 + x1) / 2, (y0 + y1) / 2, -0.01, (x1 - x0, y1 - y0, 0.02), floor)]),
           entity("markings", ts, lines=loops, cylinders=discs)]
    xpos, xquat = data.xpos, data.xquat
    xmat = data.xmat.reshape(-1, 3, 3)
    side = 2.0 * scene.layout.box_half
    for b, (body, team) in enumerate(zip(scene.box_body, scene.layout.box_teams)):
        colour = colour_of(_shade(TEAM_COLOURS[team % len(TEAM_COLOURS)], 0.45))
        out.append(entity(f"box/{b}", ts, cubes=[cube(*xpos[body], (side, side, side), colour,
                                                      quaternion=tuple(xquat[body]))]))
    for i, (kind, team) in enumerate(zip(scene.layout.robots, scene.layout.teams)):
        torso_body = scene.torso_body[i]
        torso = xpos[torso_body]
        diameter = 2.0 * ROBOTS[kind][1].torso_radius
        colour: Colour = team_colour(team)
        leg_colour: Colour = (0.7 * colour[0], 0.7 * colour[1], 0.7 * colour[2], 1.0)
        legs = []
        for k in range(scene.hip_body.shape[1]):
            shin_body = scene.shin_body[i, k]
            foot = xpos[shin_body] + xmat[shin_body] @ scene.foot_vector[k]
            legs.append(lines([tuple(torso), tuple(xpos[scene.hip_body[i, k]]), tuple(xpos[shin_body]), tuple(foot)],
                              leg_colour, 0.08, kind="strip"))
        fallen = xmat[torso_body][2, 2] < 0
        forward = xmat[torso_body][:, 0]
        out.append(entity(f"agent/{i}", ts, spheres=[sphere(*torso, (diameter,) * 3, leg_colour if fallen else colour)],
                          lines=legs, arrows=[arrow(*torso, float(np.arctan2(forward[1], forward[0])), 0.6,
                                                    (0.98, 0.98, 0.98, 1.0))]))
    return out


def camera_picture(model: mujoco.MjModel, data: mujoco.MjData, width: int = 480, height: int = 360,
                   distance: float = 9.0, elevation: float = -50.0) -> np.ndarray:
    """A perspective ``uint8[H, W, 3]`` picture from MuJoCo's renderer, looking at the arena
    centre. Needs an OpenGL context (``MUJOCO_GL=egl`` on a headless machine with EGL); raises
    ``RuntimeError`` saying so where none can be made."""
    if not os.environ.get("MUJOCO_GL") and not os.environ.get("DISPLAY"):
        raise RuntimeError("MuJoCo's renderer needs OpenGL: there is no display and MUJOCO_GL is not set; on a "
                           "headless machine set MUJOCO_GL=egl (or osmesa) before importing mujoco, or use "
                           "render_topdown(), which needs no GL")
    try:
        renderer = mujoco.Renderer(model, height, width)
    except Exception as exc:  # GL missing or no display: the cause is the platform, say so
        raise RuntimeError(
            f"MuJoCo's renderer could not make an OpenGL context ({exc}); on a headless machine set "
            "MUJOCO_GL=egl (or osmesa) before importing mujoco, or use render_topdown(), which needs no GL"
        ) from exc
    camera = mujoco.MjvCamera()
    camera.lookat[:] = (0.0, 0.0, 0.0)
    camera.distance = distance
    camera.elevation = elevation
    camera.azimuth = 90.0
    try:
        renderer.update_scene(data, camera=camera)
        return renderer.render().copy()
    finally:
        renderer.close()
