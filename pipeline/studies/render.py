"""The synthetic signer fingerspelling a word (or moving as a .pose file of MediaPipe Holistic keypoints says), rendered by the kernels to a lossless FFV1 video (the reference for
quality measurements), with the per-pixel part labels of every frame and an optional PNG preview."""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from media.errors import SigncastError

VIDEO_SUFFIXES = (".mkv", ".avi", ".nut")   # containers that hold FFV1 (MP4 players do not play it: refused)
BYTES_PER_PIXEL = 4                                 # held until written: RGB frames (3) and labels (1)
PART_NAMES = ("background", "body", "head", "left_hand", "right_hand")


@dataclass(frozen=True)
class RenderWordSettings:
    """language, word: what the avatar fingerspells (None with `pose`); output: the video file; labels: a .npz for the label frames
    (T, H, W) uint8; preview: a PNG of frame preview_frame (None: the middle one); size: (width, height) pixels;
    fps: frames per second (None: 25 for a word, the file's own for a .pose); look: shaded or flat; segmented: an
    FBA-style segmented body; backend: kernels; pose: a .pose file to retarget instead of a word; jitter_filter:
    one-euro, binomial or off for its keypoints (None: media.retarget's default); framing: "source" frames the avatar
    like the .pose's person (one camera zoom and shift per clip, media.framing), "full-figure" the signing space;
    None: "source" with a .pose, "full-figure" for a word."""

    language: str | None
    word: str | None
    output: Path
    labels: Path | None = None
    preview: Path | None = None
    preview_frame: int | None = None
    size: tuple[int, int] = (352, 288)
    fps: float | None = 25.0
    look: str = "shaded"
    segmented: bool = False
    backend: str = "auto"
    pose: Path | None = None
    jitter_filter: str | None = None
    framing: str | None = None


def check(settings: RenderWordSettings) -> str:
    """Refuse bad settings before any work (one-line SigncastError); the backend the kernels will use."""
    from kernels import backends
    from media.domain import check_size
    from media.render import check_backend, check_look
    from pipeline.studies.shared import check_source
    if Path(settings.output).suffix.lower() == ".mp4":
        raise SigncastError(f"cannot write video {settings.output}: render writes lossless FFV1, which MP4 players "
                            f"do not play; name it .mkv")
    check_size(*settings.size)
    check_backend(settings.backend)
    check_look(settings.look)
    check_source(settings.language, settings.word, settings.pose, settings.fps, settings.jitter_filter)
    if settings.framing is not None:
        from media.framing import check_framing
        if check_framing(settings.framing) == "source" and settings.pose is None:
            raise SigncastError("--framing source frames the avatar like the person of a .pose: give --pose "
                                "(a fingerspelled word is framed as the full figure)")
    return backends.describe(settings.backend)   # a backend that cannot run here fails now, in one line


def run(settings: RenderWordSettings, *, progress: bool = True, notify: Callable[[str], object] | None = None) -> str:
    """Render and write the files; a one-line summary (frames, size, bytes, speed). notify: called with one-line
    notices: the backend auto chose, once the work is known to fit; a .pose that shows no hand."""
    from tqdm import tqdm

    from media.avatar import load_avatar
    from media.render import RenderSettings, render_motion
    from media.video_io import write_video
    from pipeline.checks import check_memory
    from pipeline.studies.shared import framed_source_motion

    width, height = settings.size
    motion, source, framing = framed_source_motion(settings.language, settings.word, settings.pose, settings.fps,
                                                   settings.jitter_filter, settings.size, settings.framing, notify,
                                                   backend=settings.backend)
    if settings.preview_frame is not None and not 0 <= settings.preview_frame < motion.n_frames:
        raise SigncastError(f"--preview-frame {settings.preview_frame} outside 0..{motion.n_frames - 1}")
    check_memory(motion.n_frames, width, height, BYTES_PER_PIXEL, "render")
    chosen = check(settings)
    avatar = load_avatar()
    render_settings = RenderSettings(width=width, height=height, look=settings.look, segmented=settings.segmented,
                                     backend=settings.backend, framing=framing)
    if settings.backend == "auto" and notify:
        notify(f"backend auto chose {chosen}")
    started = time.perf_counter()
    with tqdm(total=motion.n_frames, desc="render", unit="frame", file=sys.stderr, leave=False,
              disable=not progress) as bar:
        frames, labels = render_motion(avatar, motion, render_settings, progress=bar.update)
    rendered = time.perf_counter()
    size = write_video(settings.output, frames, motion.fps)
    elapsed = time.perf_counter() - started
    if settings.labels is not None:
        np.savez_compressed(settings.labels, labels=labels, fps=np.float64(motion.fps), part_names=np.array(PART_NAMES))
    if settings.preview is not None:
        middle = motion.n_frames // 2 if settings.preview_frame is None else settings.preview_frame
        _write_png(settings.preview, frames[middle])
    return (f"{settings.output}: {source}, {motion.n_frames} frames {width}x{height} at "
            f"{motion.fps:g} fps, {settings.look}{', segmented' if settings.segmented else ''}, "
            f"{_framing_words(framing)}, {size} bytes; "
            f"rendered at {motion.n_frames / (rendered - started):.1f} frames/s, "
            f"{motion.n_frames / elapsed:.1f} frames/s with encoding")


def _framing_words(framing) -> str:
    if framing is None:
        return "full figure"
    turn = f", turn {framing.turn:+.1f} deg" if framing.turn else ""
    return (f"framed like the person (zoom {framing.scale:.3f}, shift {framing.shift[0]:+.3f}, {framing.shift[1]:+.3f} "
            f"frames{turn})")


def _write_png(path: Path, rgb: np.ndarray) -> None:
    import cv2
    if not cv2.imwrite(str(path), rgb[..., ::-1]):
        raise SigncastError(f"cannot write PNG {path}")
