"""g2o reader: the hand-written Killian-format excerpt and its refused lines."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from evmap.sources.logs.g2o import read_g2o
from evmap.sources.logs.scan import LogError

KILLIAN = Path(__file__).parent / "data" / "logs" / "killian-excerpt.g2o"
SCAN = "ROBOTLASER1 0 -1.5708 3.14159 0.785398 81.9 0.01 0 5 2 2 2 2 2 0 0 0 0 0 0 0 0 0 0 0 0 1.0 h 1.0"


def test_killian_excerpt_scans_at_their_vertices() -> None:
    records = list(read_g2o(KILLIAN))
    assert [r.index for r in records] == [0, 1, 2]
    np.testing.assert_allclose(records[1].robot_pose, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(records[1].scan.pose, [1.0, 0.0, 0.0])
    # the third line's laser is 0.1 m to its robot's right (+x in the log, robot heading +y): at the vertex the same
    np.testing.assert_allclose(records[2].scan.pose, [2.1, 0.5, np.pi / 2], atol=1e-6)
    assert np.isnan(records[0].scan.ranges[2])  # 81.9 = the line's maximum range: no return
    np.testing.assert_allclose(np.degrees(records[0].scan.angles), [-90, -45, 0, 45, 90], atol=1e-3)


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        ([SCAN], "x.g2o:1: ROBOTLASER1 before any VERTEX_SE2"),
        (["VERTEX_SE2 0 1 2"], "x.g2o:1: VERTEX_SE2 needs an id and x y theta"),
        (["VERTEX_SE2 0 1 nan 0"], "x.g2o:1: vertex pose (1.0, nan, 0.0) is not finite"),
        (["VERTEX_SE2 0 1 a 0"], "x.g2o:1: VERTEX_SE2 pose '1 a 0' is not three numbers"),
        (["VERTEX_SE2 0 0 0 0", SCAN.replace(" 5 2 2 2 2 2 ", " 5 2 2 2 2 ")], "x.g2o:2: ROBOTLASER1"),
        (
            ["VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 1 0 0", SCAN, SCAN.replace(" 2 0 0 0 0 0 0 0 ", " 2 0 2 0 0 2 0 0 ")],
            "x.g2o:4: ROBOTLASER1 robot pose 2.00 m from that of the first scan at the VERTEX_SE2 of line 2",
        ),
    ],
)
def test_refused_lines(tmp_path: Path, lines: list[str], message: str) -> None:
    path = tmp_path / "x.g2o"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogError) as info:
        list(read_g2o(path))
    assert message in str(info.value)
