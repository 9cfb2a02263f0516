"""Closed loop with known ground truth (benchmarks/closed_loop.py): ASL 'HI' fingerspelled by the avatar, rendered
shaded at 352x288, its landmarks extracted, retargeted as any .pose, and compared with the original motion.

Bounds are the values measured with the default One-Euro filter and the default (lifting) retargeting
(benchmarks/closed_loop.py --filters one-euro --methods lifting, 2026-12-06, Warp-CPU render; the NumPy and
OpenCL/PoCL renders give the same figures to 0.05 deg and 0.1 px) plus a small margin: right hand found in all 36 frames (bound 95%); extracted
landmarks 3.2 px from the original's projected joints on average (bound 4.5 px, a sixth of the 25 px palm), the
extracted wrist 3.8 px (bound 4.5); the retargeted hand 9.0 px (bound 10.5) and wrist 7.5 px (bound 9); joint
angles torso 0.8 deg (bound 1.5), arm 10.9 deg (bound 13) and fingers 20.3 deg (bound 23). The fingers stay far
from issue 34's 10 deg because the extractor's own phalanx directions are 23 deg (image) and 31.5 deg (world
landmarks) off on this render (bounds 27 and 36: `landmark_errors`, the floor; docs/retargeting.md, "Closed loop
with depth"). The landmark model (ai_edge_litert) is a core dependency: the test never skips for want of it."""
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@pytest.fixture(scope="module")
def loop():
    from benchmarks import closed_loop
    return closed_loop.run_loop("ase", "HI", (352, 288))


def test_closed_loop_recovers_the_rendered_hand_and_joint_angles(loop):
    from benchmarks import closed_loop
    result = closed_loop.measure(loop)
    assert "right" in result["hands"]
    assert result["frames"] == 36 and result["found_share"] >= 0.95
    assert result["hand_px"]["extracted"]["mean"] < 4.5
    assert result["wrist_px"]["extracted"]["mean"] < 4.5
    assert result["hand_px"]["retargeted"]["mean"] < 10.5
    assert result["wrist_px"]["retargeted"]["mean"] < 9.0
    angles = result["angles_deg"]
    assert angles["torso"]["mean"] < 1.5
    assert angles["arm"]["mean"] < 13.0
    assert angles["fingers"]["mean"] < 23.0


def test_extractor_floor_per_phalanx(loop):
    """The extractor's own phalanx directions against the original's (the floor of any retargeting that follows
    them): 15 phalanges over the 36 frames, image 23.0 deg, world landmarks 31.5 deg mean (bounds 27 and 36)."""
    from benchmarks import closed_loop
    floor = closed_loop.landmark_errors(loop)
    assert floor["image"]["n"] == floor["world"]["n"] == 15 * 36
    assert floor["image"]["mean"] < 27.0
    assert floor["world"]["mean"] < 36.0


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


def test_close_framing_projects_onto_the_framed_render():
    """With a head-and-torso zoom (1.7) the loop's camera is the framed render's: the original's projected right
    middle knuckle lies on the framed render's right-hand pixels, and the palm is about 1.7 times as long as in the
    full figure."""
    import numpy as np

    from benchmarks import closed_loop
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import RenderSettings, render_motion, signing_space_camera

    avatar = load_avatar()
    motion = fingerspell("ase", "HI", fps=25.0)
    middle = motion.frames(motion.n_frames // 2, motion.n_frames // 2 + 1)
    framing = closed_loop.close_framing(avatar, motion, (352, 288), 1.7)
    _, labels = render_motion(avatar, middle, RenderSettings(352, 288, look="flat", framing=framing))
    joints = closed_loop.hand_joints(avatar.skeleton, middle, "R")
    full = np.asarray(signing_space_camera(avatar, 352, 288), np.float64)
    framed = closed_loop.project(np.asarray(framing.camera(full, 352, 288), np.float64), joints, (352, 288))[0]
    x, y = np.round(framed[9]).astype(int)
    assert labels[0, y - 1:y + 2, x - 1:x + 2].max() == 4
    unframed = closed_loop.project(full, joints, (352, 288))[0]
    ratio = np.linalg.norm(framed[9] - framed[0]) / np.linalg.norm(unframed[9] - unframed[0])
    assert abs(ratio - 1.7) < 0.01


def test_extraction_keeps_the_hand_models_world_landmarks(loop):
    """signcast pose's extractor keeps the hand landmark model's 21 world landmarks (metres) where it finds the
    hand: on the avatar's right hand the palm (wrist -> middle knuckle) measures 5-15 cm."""
    import numpy as np

    world = loop.clip.points["RIGHT_HAND_WORLD_LANDMARKS"]
    found = loop.clip.confidence["RIGHT_HAND_LANDMARKS"][:, 0] > 0
    assert np.array_equal(loop.clip.confidence["RIGHT_HAND_WORLD_LANDMARKS"][:, 0] > 0, found)
    palm = np.linalg.norm(world[found, 9] - world[found, 0], axis=-1)
    assert np.all((palm > 0.05) & (palm < 0.15))


def test_floor_helpers_on_hand_made_hands():
    """landmark_errors' helpers on hand-made cases: a hand turned as a whole and shifted comes back onto the
    original (0 deg per phalanx after the per-frame rotation); the same hand mirrored in depth gets every
    out-of-plane phalanx's depth sign wrong, and itself gets them all right."""
    import numpy as np

    from benchmarks import closed_loop
    from media import rotations

    rng = np.random.default_rng(3)
    hand = rng.normal(scale=0.05, size=(4, 21, 3))
    turn = rotations.from_axis_angle(np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]), 1.1)
    turned = rotations.rotate(np.broadcast_to(turn, (4, 21, 4)), hand) + np.array([0.2, -0.1, 0.4])
    back = closed_loop._rotated_onto(turned, hand)
    heads, tails = (np.array(ends) for ends in zip(*closed_loop.PHALANGES))
    error = closed_loop._angles_deg(back[:, tails] - back[:, heads], hand[:, tails] - hand[:, heads])
    assert error.max() < 1e-4          # degrees: arccos near 1 resolves ~1e-6
    unaligned = closed_loop._angles_deg(turned[:, tails] - turned[:, heads], hand[:, tails] - hand[:, heads])
    assert unaligned.mean() > 20.0
    assert closed_loop.depth_sign_share(hand, hand) == 1.0
    assert closed_loop.depth_sign_share(hand * np.array([1.0, 1.0, -1.0]), hand) == 0.0
