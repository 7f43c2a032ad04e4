"""The evidential occupancy grid and its ROS map_server export."""

import numpy as np
import pydantic
import pytest
import shapely
import yaml

from evidential import Frame, MassFunction, combine, combine_batch
from evmap.maps import BeliefMap
from evmap.maps.occupancy import (
    GRID_FRAME,
    OccupancyParams,
    evidential_grid,
    grid_geometry,
    occupancy_from_masses,
    polygon_cells,
    segment_cells,
    write_ros_map,
)

FRAME = Frame(["real", "noise"])
RES = 0.1


def mass(real: float) -> MassFunction:
    return MassFunction(FRAME, {"real": real, "real|noise": 1 - real})


def cell_boxes(origin, shape, resolution):
    rows, cols = np.divmod(np.arange(shape[0] * shape[1]), shape[1])
    x0, y0 = origin[0] + cols * resolution, origin[1] + rows * resolution
    return shapely.box(x0, y0, x0 + resolution, y0 + resolution)


def test_segment_cells_are_exactly_the_cells_whose_inside_the_segment_crosses():
    rng = np.random.default_rng(0)
    origin, shape = (-0.37, -0.21), (50, 50)
    boxes = cell_boxes(origin, shape, RES)
    p = rng.uniform(-0.15, 4.5, (60, 2))
    q = np.where(rng.random((60, 1)) < 0.2, p, p + rng.uniform(-1.5, 1.5, (60, 2)))  # some points
    q[:5, 1] = p[:5, 1]  # horizontal segments
    q[5:10, 0] = p[5:10, 0]  # vertical ones
    q = np.clip(q, -0.15, 4.5)
    cells, seg = segment_cells(p, q, origin, RES, shape)
    for i in range(len(p)):
        if (p[i] == q[i]).all():
            expected = set(np.flatnonzero(shapely.contains_xy(boxes, *p[i])))
        else:
            line = shapely.LineString([p[i], q[i]])
            expected = set(np.flatnonzero(shapely.relate_pattern(boxes, line, "T********")))
        assert set(cells[seg == i].tolist()) == expected, i


def test_polygon_cells_are_the_cells_whose_centre_is_inside():
    rng = np.random.default_rng(1)
    origin, shape = (0.0, 0.0), (60, 70)
    rows, cols = np.divmod(np.arange(shape[0] * shape[1]), shape[1])
    centres = np.stack([(cols + 0.5) * RES, (rows + 0.5) * RES], axis=1)
    room = shapely.box(0.52, 0.33, 4.01, 5.27).difference(shapely.box(1.03, 1.11, 2.07, 2.49))  # with a hole
    blob = shapely.Point(6.0, 3.0).buffer(0.77)
    star = shapely.Polygon(rng.uniform(0, 1, (9, 2)) * [2, 1.5] + [4.5, 0.2]).convex_hull
    for geometry in (room, shapely.MultiPolygon([room, blob, star]), shapely.MultiPolygon()):
        mask = polygon_cells(geometry, origin, RES, shape)
        assert mask.shape == shape
        assert (mask.ravel() == shapely.contains_xy(geometry, *centres.T)).all()


def test_cells_outside_the_grid_are_clipped():
    mask = polygon_cells(shapely.box(-5, -5, 0.25, 0.15), (0.0, 0.0), RES, (3, 4))
    assert mask.astype(int).tolist() == [[1, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]


def test_grid_masses_combine_free_and_the_strongest_object_by_the_rule():
    open_space = shapely.box(0, 0, 1, 1)
    p = [[0.55, 0.05], [0.55, 0.95], [0.25, 0.25]]
    q = [[0.55, 0.95], [0.55, 0.95], [0.25, 0.25]]  # a line, a point on it, a point alone
    belief = [0.3, 0.9, 0.6]
    bounds = (0, 0, 1, 1)
    params = OccupancyParams(padding=0.2)
    for rule in ("dempster", "yager", "pcr6"):
        m, origin = evidential_grid(open_space, p, q, belief, bounds, RES, rule, params)
        assert m.shape == (14, 14, 4) and origin == (-0.2, -0.2)
        assert np.allclose(m.sum(axis=2), 1)

        def expect(free: bool, occupied: float, rule=rule) -> list:
            m_free = MassFunction(GRID_FRAME, {"free": 0.7, "free|occupied": 0.3} if free else {"free|occupied": 1})
            m_occ = MassFunction(GRID_FRAME, {"occupied": occupied, "free|occupied": 1 - occupied})
            return combine(m_free, m_occ, rule=rule).dense().tolist()

        def cell(x, y, m=m, origin=origin):
            return m[int((y - origin[1]) / RES), int((x - origin[0]) / RES)].tolist()

        assert cell(-0.15, -0.15) == [0, 0, 0, 1]  # outside the open space, nothing there
        assert cell(0.85, 0.15) == pytest.approx(expect(True, 0))
        assert cell(0.55, 0.45) == pytest.approx(expect(True, 0.3))  # the line, doubted: free evidence too
        assert cell(0.55, 0.95) == pytest.approx(expect(False, 0.9))  # the line and the stronger point, believed
        assert cell(0.25, 0.25) == pytest.approx(expect(False, 0.6))  # a believed object: no free evidence
        flat = m.reshape(-1, 4)
        free = np.tile([0, 0.7, 0, 0.3], (len(flat), 1))
        occupied = np.tile([0, 0, 0.3, 0.7], (len(flat), 1))
        assert combine_batch(free, occupied, rule=rule)[0] == pytest.approx(expect(True, 0.3))


def test_occupancy_from_masses_is_pignistic_with_unknown_where_ignorance_dominates():
    masses = np.array([[[0, 0.7, 0, 0.3], [0, 0, 0.8, 0.2], [0, 0, 0.3, 0.7], [0, 0, 0, 1], [1, 0, 0, 0],
                        [0.5, 0.1, 0.3, 0.1], [0, 0.5, 0, 0.5]]])  # fmt: skip
    grid = occupancy_from_masses(masses)
    assert grid.dtype == np.int8 and grid.tolist() == [[15, 90, -1, -1, -1, 70, 25]]
    assert occupancy_from_masses(masses, OccupancyParams(ignorance_threshold=0.75)).tolist() == [
        [15, 90, 65, -1, -1, 70, 25]
    ]


def test_params_are_validated_and_documented():
    with pytest.raises(pydantic.ValidationError):
        OccupancyParams(free_mass=1.0)
    with pytest.raises(pydantic.ValidationError):
        OccupancyParams(colour="red")
    assert all(field.description for field in OccupancyParams.model_fields.values())
    with pytest.raises(ValueError, match="resolution"):
        grid_geometry((0, 0, 1, 1), 0.0, OccupancyParams())
    with pytest.raises(ValueError, match="max_cells"):
        grid_geometry((0, 0, 100, 100), 0.001, OccupancyParams())


def test_a_resolution_coarser_than_the_map_and_params_of_another_type_are_answered_clearly(l_room):
    """A resolution of 1e300 m made an empty grid and an IndexError; a dict of params an AttributeError."""
    assert l_room.occupancy_grid(1e300).shape == (1, 1)
    with pytest.raises(TypeError, match="params must be an OccupancyParams \\(or None\\), got dict"):
        l_room.occupancy_grid(0.05, {"unknown": "blocked"})


@pytest.fixture
def l_room() -> BeliefMap:
    """An asymmetric room: a long wall at the bottom (y = 0), a short one up the left side, a target top right."""
    bm = BeliefMap(FRAME)
    bm.add_point("C1", (0, 0), "corner", mass(0.9))
    bm.add_point("E1", (3, 0), "endpoint", mass(0.9))
    bm.add_point("E2", (0, 1), "endpoint", mass(0.9))
    bm.add_point("U1", (2.5, 1.5), "unidentified", mass(0.8))
    bm.add_line("L1", "C1", "E1", mass(0.95))
    bm.add_line("L2", "C1", "E2", mass(0.4))
    bm.open_space = shapely.box(0.05, 0.05, 2.0, 1.5)
    return bm


def test_occupancy_grid_of_a_map_follows_ros_orientation(l_room):
    params = OccupancyParams(padding=0.2)
    grid = l_room.occupancy_grid(RES, params)
    masses, origin = l_room.occupancy_masses(RES, params)
    assert grid.dtype == np.int8 and grid.shape == masses.shape[:2] == (19, 34) and origin == (-0.2, -0.2)
    assert grid.min() >= -1 and grid.max() <= 100
    wall_row = int((0.0 - origin[1]) / RES)  # y = 0 is near the bottom: row 2 of 19
    assert wall_row == 2 and (grid[wall_row, 2:32] >= 85).all() and (grid[wall_row + 1 : 12, 2:32] < 85).all()
    assert (grid[-1] == -1).all() and grid[0, 0] == -1  # unknown margins
    target = grid[int((1.5 - origin[1]) / RES), int((2.5 - origin[0]) / RES)]
    assert target == round(100 * (0.8 + 0.2 / 2))
    assert grid[int((1.0 - origin[1]) / RES), int((1.0 - origin[0]) / RES)] == 15  # free: 100 * 0.3 / 2
    left_wall = grid[5:10, int((0.0 - origin[0]) / RES)]
    assert (left_wall == 29).all()  # free 0.7 (cell centres on the open space's edge) with occupied 0.4


def test_an_empty_map_has_no_grid():
    with pytest.raises(ValueError, match="empty"):
        BeliefMap(FRAME).occupancy_grid()


def read_pgm(path):
    """Parse a binary PGM (P5) with numpy: header tokens, then width * height bytes."""
    data = path.read_bytes()
    tokens, pos = [], 0
    while len(tokens) < 4:
        while data[pos : pos + 1].isspace():
            pos += 1
        if data[pos : pos + 1] == b"#":
            pos = data.index(b"\n", pos) + 1
            continue
        end = pos
        while not data[end : end + 1].isspace():
            end += 1
        tokens.append(data[pos:end].decode())
        pos = end
    magic, width, height, maxval = tokens[0], int(tokens[1]), int(tokens[2]), int(tokens[3])
    pixels = np.frombuffer(data, dtype=np.uint8, offset=pos + 1)
    return magic, maxval, pixels.reshape(height, width)


def test_ros_map_pair_reads_back_as_map_server_would(l_room, tmp_path):
    params = OccupancyParams(padding=0.2)
    grid = l_room.occupancy_grid(RES, params)
    pgm, meta = l_room.save_ros_map(tmp_path / "room", RES, params)
    assert (pgm, meta) == (tmp_path / "room.pgm", tmp_path / "room.yaml")
    info = yaml.safe_load(meta.read_text())
    assert info == {"image": "room.pgm", "resolution": RES, "origin": [-0.2, -0.2, 0.0], "negate": 0,
                    "occupied_thresh": 0.65, "free_thresh": 0.196, "mode": "trinary"}  # fmt: skip
    magic, maxval, pixels = read_pgm(pgm)
    assert magic == "P5" and maxval == 255 and pixels.shape == grid.shape
    assert set(np.unique(pixels).tolist()) <= {0, 205, 254}
    # map_server (trinary, negate 0): p = (255 - pixel) / 255; occupied if p > 0.65, free if p < 0.196
    p = (255 - pixels.astype(float)) / 255
    loaded = np.where(p > info["occupied_thresh"], 100, np.where(p < info["free_thresh"], 0, -1))
    loaded = np.flipud(loaded)  # image row 0 is the highest y; grid row 0 the lowest
    expected = np.where(grid >= 65, 100, np.where((grid >= 0) & (grid <= 25), 0, -1))
    assert (loaded == expected).all()
    assert (pixels[-3] == 0).sum() >= 29 and (pixels[2] == 0).sum() == 0  # the bottom wall is near the image bottom
    assert set(tmp_path.iterdir()) == {pgm, meta}  # no temporary file left behind


def test_write_ros_map_refuses_a_bad_grid(tmp_path):
    with pytest.raises(ValueError, match="2D"):
        write_ros_map(np.zeros(3, dtype=np.int8), 0.05, (0, 0), tmp_path / "x")


@pytest.mark.parametrize(("policy", "value", "pgm"), [("unknown", -1, 205), ("blocked", 100, 0), ("free", 0, 254)])
def test_unknown_cells_hold_the_policys_value(tmp_path, policy, value, pgm):
    """Unknown cells (-1 by default) are blocked or free on request; known cells keep their values."""
    masses = np.array([[[0, 0.7, 0, 0.3], [0, 0, 0.8, 0.2], [0, 0, 0.3, 0.7], [1.0, 0, 0, 0]]])
    grid = occupancy_from_masses(masses, OccupancyParams(unknown=policy))
    assert grid.tolist() == [[15, 90, value, value]]
    image, _ = write_ros_map(grid, 0.05, (0.0, 0.0), tmp_path / "map")
    assert image.read_bytes()[-4:] == bytes([254, 0, pgm, pgm])


def test_an_unknown_policy_outside_the_three_is_refused():
    with pytest.raises(ValueError, match="unknown"):
        OccupancyParams(unknown="maybe")


def test_a_believed_wall_is_occupied_in_the_grid_even_where_its_cells_reach_into_free_space():
    """A wall of belief 0.6 whose cells have their centres just on the free side: combined with the free space,
    they read 41 (unknown in the ROS map, where a planner may go); a believed surface's cell takes no free
    evidence, so they read 80 (occupied); a doubted one (0.4) still combines with the free space."""
    open_space = shapely.box(0, 0, 2, 1.02)  # free up to 2 cm above the wall at y = 1
    wall = [[0.0, 1.0]], [[2.0, 1.0]]
    for belief, value in ((0.6, 80), (0.4, None)):
        m, origin = evidential_grid(open_space, *wall, [belief], (0, 0, 2, 1.2), 0.1, "dempster", OccupancyParams())
        on_wall = occupancy_from_masses(m)[int((1.0 - origin[1]) / 0.1), 5:15]
        if value is not None:
            assert (on_wall == value).all(), on_wall
        else:
            assert (on_wall < 65).all() and (on_wall > 25).all(), on_wall


def test_a_log_s_ros_map_is_coarser_where_its_grid_would_exceed_max_cells():
    """A 412 m campus loop mapped in full, then refused at writing the grid (8,280 x 8,280 cells at 5 cm):
    nothing was written. Its ROS pair is now written at the finest doubled resolution that fits."""
    from evmap.maps.app.artefacts import ROS_RESOLUTION, ros_resolution

    bm = BeliefMap(["real", "noise"])
    bm.open_space = shapely.box(0, 0, 20, 30)
    assert ros_resolution(bm) == ROS_RESOLUTION == 0.05
    bm.open_space = shapely.box(0, 0, 400, 400)  # 8,000 x 8,000 cells at 5 cm, more than 50 million
    assert ros_resolution(bm) == 0.1
    assert bm.occupancy_grid(0.1).shape == (4005, 4005)  # with the padding
