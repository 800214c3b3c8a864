"""The 2D engine's shots: the tiles a shell crosses, in order, and the first it meets; bodies hit
before tiles behind them; breakable tiles cleared from the map and the space; shells that pass
the shooter and the seats they may not hit; the map's edge."""

from __future__ import annotations

import numpy as np
import pymunk
import pytest

from arena_league.envs.physics2d.shots import EMPTY, Hit, Shells, ThrustFacing, TileMap

BRICK, STEEL = 1, 2


def tile_map(*solid: tuple[int, int, int]) -> tuple[TileMap, pymunk.Space]:
    """A 5 x 5 map of unit tiles over [0, 5]^2 with the given ``(row, col, kind)`` tiles, in a space."""
    tiles = TileMap(5, 5, 1.0, (0.0, 0.0), breakable=(BRICK,))
    kinds = np.zeros((5, 5), dtype=np.int8)
    for row, col, kind in solid:
        kinds[row, col] = kind
    space = pymunk.Space()
    tiles.build(space, kinds)
    return tiles, space


def test_the_walk_finds_the_first_solid_tile_along_the_segment_and_where_it_enters():
    tiles, _ = tile_map((2, 3, STEEL), (2, 4, BRICK))
    t, row, col = tiles.first_solid(0.5, 2.5, 4.5, 2.5)
    assert (row, col) == (2, 3) and t == pytest.approx(2.5 / 4)
    assert tiles.first_solid(0.5, 2.5, 2.5, 2.5)[0] == np.inf  # stops short of the steel


def test_a_diagonal_walk_crosses_tiles_in_order_and_does_not_miss_a_corner_tile():
    tiles, _ = tile_map((1, 2, STEEL))
    # from (0.5, 0.5) to (3.5, 1.9): it enters tile (1, 2) through its left face at x = 2
    t, row, col = tiles.first_solid(0.5, 0.5, 3.5, 1.9)
    assert (row, col) == (1, 2) and t == pytest.approx(0.5)


def test_leaving_the_map_reports_the_edge():
    tiles, _ = tile_map()
    t, row, col = tiles.first_solid(4.5, 2.5, 6.5, 2.5)
    assert (row, col) == (-1, -1) and t == pytest.approx(0.25)


def test_build_adds_one_static_box_per_run_of_solid_tiles_and_clear_splits_a_run():
    tiles, space = tile_map((0, 0, BRICK), (2, 1, BRICK), (2, 2, STEEL), (2, 3, BRICK), (4, 4, STEEL))
    assert len(space.shapes) == 3
    boxes = sorted(tuple(round(v) for v in (s.bb.left, s.bb.bottom, s.bb.right, s.bb.top)) for s in space.shapes)
    assert boxes == [(0, 0, 1, 1), (1, 2, 4, 3), (4, 4, 5, 5)]

    def solid_at(x: float, y: float) -> bool:
        return space.point_query_nearest((x, y), 0.0, pymunk.ShapeFilter()) is not None

    tiles.clear(2, 2)  # the middle of the run: a box on either side
    assert len(space.shapes) == 4 and tiles.kinds[2, 2] == EMPTY
    assert solid_at(1.5, 2.5) and not solid_at(2.5, 2.5) and solid_at(3.5, 2.5)
    tiles.clear(2, 1)
    tiles.clear(0, 0)
    assert len(space.shapes) == 2 and not solid_at(1.5, 2.5) and not solid_at(0.5, 0.5)
    tiles.clear(0, 0)  # already empty: nothing changes
    tiles.build(space, np.zeros((5, 5), dtype=np.int8))  # a new layout replaces the old boxes
    assert len(space.shapes) == 0


def test_a_box_goes_from_match_to_match_onto_the_new_space_static_body():
    kinds = np.zeros((5, 5), dtype=np.int8)
    kinds[2, 1:4] = BRICK
    tiles, first = tile_map()
    tiles.build(first, kinds)
    (box,) = first.shapes
    second = pymunk.Space()
    tiles.build(second, kinds)  # the first space still holds the box: it leaves it
    assert list(second.shapes) == [box] and box.body is second.static_body and not first.shapes
    assert second.point_query_nearest((2.5, 2.5), 0.0, pymunk.ShapeFilter()) is not None
    tiles.clear(2, 2)
    tiles.build(second, kinds)  # the run as a whole again: the same box, the halves leave
    assert list(second.shapes) == [box]


def test_a_shell_breaks_a_brick_and_stops_at_steel():
    tiles, space = tile_map((2, 2, BRICK), (2, 4, STEEL))
    shells = Shells(np.ones((1, 1), dtype=bool), speed=10.0, body_radius=0.4)
    shells.fire(0, (0.5, 2.5), (1.0, 0.0))
    hits = shells.advance(0.2, tiles, np.zeros((1, 2)) + 9.0, np.ones(1, dtype=bool))
    assert hits == [Hit(0, 2.0, 2.5, row=2, col=2, kind=BRICK, broken=True)]
    assert tiles.kinds[2, 2] == EMPTY and len(space.shapes) == 1 and not shells.flying[0]
    shells.fire(0, (0.5, 2.5), (1.0, 0.0))
    hits = shells.advance(0.4, tiles, np.zeros((1, 2)) + 9.0, np.ones(1, dtype=bool))
    assert hits == [Hit(0, 4.0, 2.5, row=2, col=4, kind=STEEL, broken=False)]
    assert tiles.kinds[2, 4] == STEEL


def test_a_shell_flies_on_when_nothing_is_in_reach_and_stops_at_the_edge():
    tiles, _ = tile_map()
    shells = Shells(np.ones((1, 1), dtype=bool), speed=10.0, body_radius=0.4)
    shells.fire(0, (0.5, 0.5), (0.0, 1.0))
    far = np.full((1, 2), 9.0)
    assert shells.advance(0.2, tiles, far, np.ones(1, dtype=bool)) == []
    assert shells.xy[0] == pytest.approx((0.5, 2.5)) and shells.flying[0]
    assert shells.advance(0.3, tiles, far, np.ones(1, dtype=bool)) == [Hit(0, 0.5, pytest.approx(5.0))]


def test_a_body_in_front_of_a_tile_is_hit_first_and_the_shooter_never_is():
    tiles, _ = tile_map((2, 4, BRICK))
    shells = Shells(np.ones((2, 2), dtype=bool), speed=10.0, body_radius=0.4)
    bodies = np.array([(0.5, 2.5), (3.0, 2.5)])
    shells.fire(0, bodies[0], (1.0, 0.0))
    hits = shells.advance(0.5, tiles, bodies, np.ones(2, dtype=bool))
    assert hits == [Hit(0, pytest.approx(2.6), 2.5, seat=1)]
    assert tiles.kinds[2, 4] == BRICK


def test_seats_a_shell_may_not_hit_and_bodies_not_targetable_are_passed():
    tiles, _ = tile_map((2, 4, BRICK))
    can_hit = np.array([[False, False, True], [False, False, True], [True, True, False]])  # teammates 0 and 1
    shells = Shells(can_hit, speed=10.0, body_radius=0.4)
    bodies = np.array([(0.5, 2.5), (2.0, 2.5), (3.0, 2.5)])
    shells.fire(0, bodies[0], (1.0, 0.0))
    hits = shells.advance(0.5, tiles, bodies, np.array([True, True, False]))
    assert [hit.row for hit in hits] == [2]  # through the teammate and the untargetable body to the brick


def test_shells_move_in_seat_order_so_the_second_passes_where_the_first_broke_a_brick():
    tiles, _ = tile_map((2, 2, BRICK), (2, 4, STEEL))
    shells = Shells(np.zeros((2, 2), dtype=bool), speed=10.0, body_radius=0.4)
    shells.fire(0, (0.5, 2.5), (1.0, 0.0))
    shells.fire(1, (1.5, 2.5), (1.0, 0.0))
    hits = shells.advance(0.3, tiles, np.full((2, 2), 9.0), np.ones(2, dtype=bool))
    assert [(hit.shooter, hit.col) for hit in hits] == [(0, 2), (1, 4)]


def test_a_gun_fires_when_loaded_with_no_shell_in_flight_and_reloads_for_its_steps():
    tiles, _ = tile_map((2, 4, STEEL))
    shells = Shells(np.zeros((2, 2), dtype=bool), speed=10.0, body_radius=0.4, reload_steps=3)
    xy, heading = np.array([(0.5, 2.5), (0.5, 0.5)]), np.array([(1.0, 0.0), (1.0, 0.0)])
    both, able = np.ones(2, dtype=bool), np.array([True, False])
    assert shells.pull_triggers(both, xy, heading, able) == [0]  # seat 1 may not fire
    fired = []
    for step in range(8):
        shells.advance(0.1, tiles, np.full((2, 2), 9.0), np.ones(2, dtype=bool))
        shells.reload()
        fired += [step] * len(shells.pull_triggers(both, xy, heading, able))
    # the shell reaches the steel 3.5 on, on the fourth step: in flight until then, then loaded
    assert fired == [3, 7] and shells.loaded_in.tolist() == [3, 0]


def test_a_seat_faces_the_way_it_is_pushed_in_the_world_and_a_weak_push_keeps_its_heading():
    heading = np.array([0.0, 1.0, 0.0, 1.0])
    thrust = [0.6, 0.8, 0.1, 0.0]
    ThrustFacing(np.array([(-1.0, 1.0), (1.0, 1.0)]), 0.3).face(thrust, [1.0, 0.1], heading)
    assert heading.tolist() == [-0.6, 0.8, 0.0, 1.0]  # seat 0's frame is mirrored in x
    ThrustFacing(np.array([(1.0, 1.0), (-1.0, -1.0)]), 0.3).face(thrust[:2] * 2, [1.0, 1.0], heading)
    assert heading.tolist() == [0.6, 0.8, -0.6, -0.8]


def test_facing_a_fixed_move_looks_up_what_facing_its_thrust_computes():
    moves = [[0.0, 0.0], [1.0, 0.0], [0.6, 0.8], [-0.1, 0.2], [-0.7071067811865476, -0.7071067811865475]]
    length = np.abs(np.array(moves).view(np.complex128).reshape(-1)).tolist()
    facing = ThrustFacing(np.array([(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0)]), 0.3)
    facing.learn_moves(moves, length)
    for chosen in ([1, 2, 4], [0, 3, 2], [4, 4, 0]):
        by_thrust, by_move = np.arange(6.0), np.arange(6.0)
        facing.face([x for move in chosen for x in moves[move]], [length[move] for move in chosen], by_thrust)
        facing.face_moves(chosen, by_move)
        assert by_move.tobytes() == by_thrust.tobytes()


def test_shells_give_their_cells_as_numpy_would_and_their_state_as_arrays():
    tiles, _ = tile_map()
    shells = Shells(np.zeros((3, 3), dtype=bool), speed=10.0, body_radius=0.4, reload_steps=2)
    xy, heading = np.array([(0.5, 2.5), (-0.5, 0.5), (3.5, 2.5)]), np.array([(1.0, 0.0), (-0.6, -0.8), (0.0, 1.0)])
    assert shells.pull_triggers(np.ones(3, dtype=bool), xy, heading, np.ones(3, dtype=bool)) == [0, 1, 2]
    shells.advance(0.1, tiles, np.full((3, 2), 9.0), np.ones(3, dtype=bool))  # seat 1 leaves the map, 2 flies on
    assert shells.flying.tolist() == [True, False, True] and shells.loaded_in.tolist() == [2, 2, 2]
    assert shells.xy.tolist() == [[1.5, 2.5], [-0.5, 0.5], [3.5, 3.5]] and shells.direction.tolist() == heading.tolist()
    flags = shells.flying[:, None]
    hidden = np.concatenate([(shells.xy * flags).reshape(-1), (shells.direction * flags).reshape(-1),
                             shells.flying.astype(np.float64)])
    assert np.array(shells.cells(hide_idle=True)).tobytes() == hidden.tobytes()  # -0.0 where numpy has it
    shown = np.concatenate([shells.xy.reshape(-1), shells.direction.reshape(-1), shells.flying.astype(np.float64)])
    assert np.array(shells.cells()).tobytes() == shown.tobytes()
    assert shells.in_flight() and shells.reload() and shells.loaded_in.tolist() == [1, 1, 1]
