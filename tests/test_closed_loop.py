"""Closed loop with known ground truth (benchmarks/closed_loop.py): ASL 'HI' fingerspelled by the avatar, rendered
shaded at 352x288, its landmarks extracted, retargeted as any .pose, and compared with the original motion.

Bounds are the measured values (docs/retargeting.md, default One-Euro filter) with margin: right hand found in all
37 frames (bound 90%); extracted landmarks 3.6 px from the original's projected joints on average (bound 6 px, a
quarter of the 22 px palm); the retargeted wrist 9 px (bound 14 px); joint angles torso 0.9 deg (bound 3), arm
17 deg (bound 25) and fingers 28 deg (bound 45: the phalanges' depth signs are a per-frame choice, and the mean
moves between 27 and 41 deg with the filter and the frame size)."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

pytest.importorskip("ai_edge_litert")


@pytest.fixture(scope="module")
def loop():
    from benchmarks import closed_loop
    return closed_loop.run_loop("ase", "HI", (352, 288))


def test_closed_loop_recovers_the_rendered_hand_and_joint_angles(loop):
    from benchmarks import closed_loop
    result = closed_loop.measure(loop)
    assert "right" in result["hands"]
    assert result["found_share"] >= 0.9
    assert result["hand_px"]["extracted"]["mean"] < 6.0
    assert result["wrist_px"]["extracted"]["mean"] < 6.0
    assert result["wrist_px"]["retargeted"]["mean"] < 14.0
    angles = result["angles_deg"]
    assert angles["torso"]["mean"] < 3.0
    assert angles["arm"]["mean"] < 25.0
    assert angles["fingers"]["mean"] < 45.0


def test_projection_matches_the_render(loop):
    """The original's projected right wrist lies on the rendered right-hand pixels (the camera is the render's)."""
    import numpy as np

    from benchmarks import closed_loop
    from media.avatar import load_avatar
    from media.render import RenderSettings, render_motion

    skeleton = load_avatar().skeleton
    middle = loop.original.frames(loop.original.n_frames // 2, loop.original.n_frames // 2 + 1)
    _, labels = render_motion(load_avatar(), middle, RenderSettings(352, 288, look="flat"))
    joints = closed_loop.project(loop.camera, closed_loop.hand_joints(skeleton, middle, "R"), (352, 288))[0]
    x, y = np.round(joints[9]).astype(int)                       # the middle finger's knuckle
    assert labels[0, y - 1:y + 2, x - 1:x + 2].max() == 4        # 4: right hand
