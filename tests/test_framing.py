"""The avatar framed like the person (media.framing): the fit, the camera it becomes, and the option reaching the
renderer from render and compare."""
import numpy as np
import pytest

from media.errors import SigncastError
from media.framing import ANCHOR_POINTS, Framing, anchor_track, fit_framing, fit_similarity, to_frame
from media.render import AvatarRenderer, RenderSettings, signing_space_camera

W, H = 176, 144


def _person_like(avatar, motion, framing: Framing) -> tuple[np.ndarray, np.ndarray]:
    """A hand-made person: pose (T, 33, 2) pixels whose anchors are the avatar's full-figure anchors moved by a known
    framing, confidence 1 there and 0 on every other point (never used)."""
    track = anchor_track(avatar, motion, signing_space_camera(avatar, W, H), W, H)
    pose = np.zeros((motion.n_frames, 33, 2))
    confidence = np.zeros((motion.n_frames, 33))
    pose[:, ANCHOR_POINTS] = framing.apply(track, W, H)
    confidence[:, ANCHOR_POINTS] = 1.0
    return pose, confidence


@pytest.mark.parametrize("known", [Framing(1.8, (-0.4, -0.1)), Framing(0.7, (0.12, 0.2)),
                                   Framing(2.1, (-0.7, 0.3), -16.0)])
def test_similarity_framing_recovers_a_known_scale_shift_and_tilt(avatar, fingerspelling_ab, known):
    motion = fingerspelling_ab.frames(0, 12)
    pose, confidence = _person_like(avatar, motion, known)
    fitted = fit_framing(avatar, motion, pose, confidence, W, H)
    assert fitted.scale == pytest.approx(known.scale, rel=1e-9)
    assert fitted.shift == pytest.approx(known.shift, abs=1e-9)
    assert fitted.turn == pytest.approx(known.turn, abs=1e-7)
    # the avatar's shoulders and face, projected by the framed camera, land on the person's (float32 camera: 0.01 px)
    framed = anchor_track(avatar, motion, fitted.camera(signing_space_camera(avatar, W, H), W, H), W, H)
    assert np.abs(framed - pose[:, ANCHOR_POINTS]).max() < 0.01


def test_a_slight_tilt_leaves_the_avatar_upright_and_noise_costs_little(avatar, fingerspelling_ab):
    motion = fingerspelling_ab.frames(0, 12)
    pose, confidence = _person_like(avatar, motion, Framing(1.5, (-0.2, -0.05), 1.5))
    noisy = pose + np.random.default_rng(3).normal(0.0, 1.0, pose.shape)       # one pixel of landmark noise
    fitted = fit_framing(avatar, motion, noisy, confidence, W, H)
    assert fitted.turn == 0.0 and fitted.scale == pytest.approx(1.5, rel=0.03)
    shoulders = anchor_track(avatar, motion, fitted.camera(signing_space_camera(avatar, W, H), W, H), W, H)[:, 7:]
    width = np.linalg.norm(pose[:, 11] - pose[:, 12], axis=-1).mean()
    assert np.linalg.norm(shoulders - pose[:, [11, 12]], axis=-1).mean() < 0.05 * width


def test_a_person_without_shoulders_or_face_is_framed_as_the_full_figure(avatar, fingerspelling_ab):
    from pipeline.studies.shared import source_framing
    from media.lexicon import SignClip
    motion = fingerspelling_ab.frames(0, 6)
    pose, confidence = _person_like(avatar, motion, Framing(1.5, (-0.2, 0.0)))
    no_shoulders = confidence.copy()
    no_shoulders[:, [11, 12]] = 0
    assert fit_framing(avatar, motion, pose, no_shoulders, W, H) is None
    no_face = confidence.copy()
    no_face[:, :11] = 0
    assert fit_framing(avatar, motion, pose, no_face, W, H) is None
    points = {"POSE_LANDMARKS": np.concatenate([pose, np.zeros((6, 33, 1))], axis=-1)}
    notes = []
    framing = source_framing(motion, SignClip(25.0, points, {"POSE_LANDMARKS": no_face}), (W, H), (W, H), "clip.mp4",
                             notes.append)
    assert framing is None and notes == ["clip.mp4: no shoulders or no face found in any frame: the avatar is framed "
                                         "as the full figure"]


def test_fit_similarity_without_rotation_is_scale_and_shift_only():
    source = np.random.default_rng(0).normal(size=(20, 2))
    scale, rotation, shift = fit_similarity(source, 2.5 * source + [3.0, -1.0], rotate=False)
    assert scale == pytest.approx(2.5) and np.array_equal(rotation, np.eye(2)) and shift == pytest.approx([3.0, -1.0])


def test_a_source_frame_of_another_aspect_is_held_whole_and_centred():
    corners = np.array([[0.0, 0.0], [500.0, 500.0]])
    assert to_frame(corners, (500, 500), (352, 288)).tolist() == [[32.0, 0.0], [320.0, 288.0]]


def test_the_framing_reaches_the_rasterizer(avatar, fingerspelling_ab):
    """The framed render is the full-figure picture zoomed and shifted, rasterized anew: the head's pixels sit where
    the framing maps the full figure's, and the head is scale^2 as large."""
    pose = fingerspelling_ab.frames(0, 1)
    framing = Framing(2.0, (-0.5, -0.05))
    full = AvatarRenderer(avatar, RenderSettings(W, H, look="flat", backend="numpy"))
    framed = AvatarRenderer(avatar, RenderSettings(W, H, look="flat", backend="numpy", framing=framing))
    assert np.allclose(framed.camera, framing.camera(full.camera, W, H))
    from media.kinematics import bone_matrices
    matrices = bone_matrices(avatar.skeleton, pose)[0]
    head_full = np.argwhere(full.render_pose(matrices)[1] == 2)[:, ::-1] + 0.5      # (x, y) pixel centres
    head_framed = np.argwhere(framed.render_pose(matrices)[1] == 2)[:, ::-1] + 0.5
    assert len(head_framed) == pytest.approx(4 * len(head_full), rel=0.05)
    assert np.allclose(head_framed.mean(axis=0), framing.apply(head_full.mean(axis=0), W, H), atol=0.5)


def test_render_frames_a_pose_like_its_person_by_default_and_the_full_figure_on_request(tmp_path, capsys):
    from media import lexicon
    from media.lexicon import SignClip
    from media.pose_file import write_pose
    from pipeline.cli import main
    clip = lexicon.read_clip(lexicon.lookup("ase", "A"))
    short = SignClip(clip.fps, {k: v[:3] for k, v in clip.points.items()}, {k: v[:3] for k, v in clip.confidence.items()})
    pose_path = tmp_path / "a.pose"
    write_pose(pose_path, short, 500, 500)
    heads = {}
    for framing in ("source", "full-figure"):
        out = tmp_path / f"{framing}.mkv"
        labels = tmp_path / f"{framing}.npz"
        assert main(["render", "--pose", str(pose_path), "-o", str(out), "--labels", str(labels), "--size", "176x144",
                     "--framing", framing, "--no-progress"]) == 0
        line = capsys.readouterr().out
        assert ("framed like the person" in line) == (framing == "source")
        heads[framing] = np.mean(np.load(labels)["labels"] == 2)
    # the lexicon's signer fills the height of a 500x500 frame with head and torso: the framed head is larger
    assert heads["source"] > 1.5 * heads["full-figure"]


def test_source_framing_needs_a_person():
    from pathlib import Path
    from pipeline.studies import render
    from pipeline.studies.shared import ScenarioSettings, check_scenario
    with pytest.raises(SigncastError, match="--framing source frames the avatar like the person of a .pose"):
        render.check(render.RenderWordSettings("ase", "A", Path("a.mkv"), framing="source"))
    with pytest.raises(SigncastError, match="unknown framing"):
        render.check(render.RenderWordSettings("ase", "A", Path("a.mkv"), framing="portrait"))
    with pytest.raises(SigncastError, match="give --video"):
        check_scenario(ScenarioSettings(framing="source"))


def test_compare_passes_its_framing_option_to_the_scenario():
    from pipeline.cli import build_parser
    from pipeline.commands.compare import scenario_fields
    from pipeline.studies.compare import CompareSettings
    parser = build_parser()
    for given, expected in ((["--framing", "full-figure"], "full-figure"), (["--framing", "source"], "source"),
                            ([], None)):
        args = parser.parse_args(["compare", "--video", "carphone", *given])
        assert CompareSettings(**scenario_fields(args)).signing.framing == expected
