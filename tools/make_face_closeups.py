"""Close-ups of the avatar's face playing MPEG-4 FAPs (media/face_rig.py), one PNG each and a contact sheet (docs/).

Each expression is one frame of FAPs at values typical of signers, rendered by the avatar renderer
(media.render.AvatarRenderer, the path the render study takes: FAPs -> face bones -> skinning ->
rasterizer; the renderer's signing-space camera is swapped for one framing the face). Writes
docs/face-neutral.png, face-mouth-open.png, face-lips-rounded.png, face-brows-raised.png,
face-blink.png and docs/face-closeups.png (the five captioned, plus the rounded lips in profile).

    python tools/make_face_closeups.py [--backend numpy] [--size 480] [--out-dir docs]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

# FAP values (FAPU of the face, see comparisons/params/fap_table.py); lip FAPs set both inner and outer.
EXPRESSIONS = {
    "neutral": {},
    "mouth-open": {"open_jaw": 500, "lower_t_midlip": -80, "lower_t_lip_lm": -60, "lower_t_lip_rm": -60,
                   "raise_b_midlip": -40, "raise_b_lip_lm": -30, "raise_b_lip_rm": -30},
    "lips-rounded": {"open_jaw": 100, "stretch_l_cornerlip": -220, "stretch_r_cornerlip": -220,
                     "push_t_lip": 150, "push_b_lip": 150, "lower_t_midlip": -80, "raise_b_midlip": -80,
                     "lower_t_lip_lm": -30, "lower_t_lip_rm": -30},
    "brows-raised": {"raise_l_i_eyebrow": 350, "raise_r_i_eyebrow": 350, "raise_l_m_eyebrow": 350,
                     "raise_r_m_eyebrow": 350, "raise_l_o_eyebrow": 350, "raise_r_o_eyebrow": 350},
    "blink": {"close_t_l_eyelid": 1024, "close_t_r_eyelid": 1024, "close_b_l_eyelid": 100, "close_b_r_eyelid": 100},
}
CAPTIONS = {"neutral": "neutral", "mouth-open": "mouth open", "lips-rounded": "lips rounded",
            "brows-raised": "brows raised", "blink": "blink", "lips-rounded-profile": "lips rounded, profile"}
FACE_HALF_HEIGHT = 0.1       # metres shown above and below the frame's centre
CAMERA_DISTANCE = 0.8        # metres from the face's centre


def expression_faps(values: dict[str, int]) -> np.ndarray:
    """(1, 68) int64 FAPs; a lip FAP named without `_o` also sets its outer-lip twin when there is one."""
    from comparisons.params.fap_table import BY_NAME, N_FAPS
    faps = np.zeros((1, N_FAPS), dtype=np.int64)
    for name, value in values.items():
        for twin in (name, name + "_o"):
            if twin in BY_NAME:
                faps[0, BY_NAME[twin].id - 1] = value
    return faps


def face_camera(avatar, side_degrees: float = 0.0) -> np.ndarray:
    """(4, 4) float32 world -> clip matrix of a square image framing the face (brows to chin), seen from
    `side_degrees` towards the avatar's left."""
    from kernels import camera
    from media.face_rig import face_landmarks
    points = face_landmarks(avatar)
    chin = avatar.skeleton.tails[avatar.skeleton.index("jaw")]
    brows = points["pupil.L"][1] + 0.03
    centre = np.array([0.0, (brows + chin[1]) / 2, points["mouth_middle"][2] - 0.03])
    angle = np.radians(side_degrees)
    eye = centre + CAMERA_DISTANCE * np.array([np.sin(angle), 0.0, np.cos(angle)])
    fovy = 2 * np.degrees(np.arctan(FACE_HALF_HEIGHT / CAMERA_DISTANCE))
    return camera.view_projection(eye, centre, fovy, 1.0, CAMERA_DISTANCE - 0.4, CAMERA_DISTANCE + 0.4)


def render_face(renderer, motion) -> np.ndarray:
    """(H, W, 3) uint8 RGB of the motion's first frame."""
    rgb, _ = next(renderer.frames(motion))
    return rgb


def captioned(tile: np.ndarray, caption: str) -> np.ndarray:
    """The tile (H, W, 3) uint8 with `caption` written in its top left corner."""
    tile = np.ascontiguousarray(tile)
    scale = tile.shape[0] / 480
    origin = (int(12 * scale), int(40 * scale))
    cv2.putText(tile, caption, origin, cv2.FONT_HERSHEY_SIMPLEX, 1.1 * scale, (0, 0, 0), max(1, int(5 * scale)), cv2.LINE_AA)
    cv2.putText(tile, caption, origin, cv2.FONT_HERSHEY_SIMPLEX, 1.1 * scale, (255, 255, 255), max(1, int(2 * scale)), cv2.LINE_AA)
    return tile


def main() -> int:
    from media.avatar import load_avatar
    from media.motion import Motion
    from media.render import AvatarRenderer, RenderSettings

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="auto", help="kernels backend: auto, warp, opencl or numpy")
    parser.add_argument("--size", type=int, default=480, help="pixels per square tile")
    parser.add_argument("--out-dir", default=str(ROOT / "docs"))
    args = parser.parse_args()
    out_dir = Path(args.out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    avatar = load_avatar()
    renderer = AvatarRenderer(avatar, RenderSettings(width=args.size, height=args.size, backend=args.backend))
    rest = Motion.rest(avatar.skeleton.names, 1)
    tiles = {}
    for name, values in EXPRESSIONS.items():
        motion = Motion(rest.fps, rest.bone_names, rest.rotations, rest.root_translation, expression_faps(values))
        renderer.camera = face_camera(avatar)
        tiles[name] = render_face(renderer, motion)
        if name == "lips-rounded":
            renderer.camera = face_camera(avatar, side_degrees=70.0)
            tiles["lips-rounded-profile"] = render_face(renderer, motion)
        path = out_dir / f"face-{name}.png"
        cv2.imwrite(str(path), cv2.cvtColor(tiles[name], cv2.COLOR_RGB2BGR))
        print(path)
    order = ("neutral", "mouth-open", "lips-rounded", "brows-raised", "blink", "lips-rounded-profile")
    cells = [captioned(tiles[name].copy(), CAPTIONS[name]) for name in order]
    sheet = np.concatenate([np.concatenate(cells[:3], axis=1), np.concatenate(cells[3:6], axis=1)], axis=0)
    path = out_dir / "face-closeups.png"
    cv2.imwrite(str(path), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
