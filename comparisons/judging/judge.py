"""What a viewer sees, measured against the signing's references: intelligibility (landmarks), letters and image
quality of one point, and the ceilings (the uncoded references re-extracted).

Inputs are data: a signing (`Signing`: reference frames and labels, its landmarks, the lossless render with its
labels and landmarks, letter spans), what the viewer sees at a point (`Viewed`: frames (T, H, W, 3) uint8 at the
reference's times, the decoded skin mask (T, H, W) bool or None, the point's record fields), and the landmarks
extracted from it (one media.lexicon.SignClip per extraction, at the measured frames). Extracting landmarks (the
landmark model, progress bars) is the study layer's (pipeline.studies.shared.extract_draws); this module computes.

References: SOURCE ("source video", the reference's landmarks: message fidelity) for every solution, and LOSSLESS
("lossless render": codec loss) for the avatar solutions (SSV, FBA, BBA). Each measure is the mean over the
extractions (comparisons.judging.landmark_draws.mean_fields), with their spread.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from comparisons.judging.intelligibility import measure, signing_hands
from comparisons.judging.landmark_draws import mean_fields
from comparisons.judging.message import message_fields
from comparisons.video import quality as image_quality
from media.domain import LOSSLESS_RENDER, SKIN_PARTS, SOURCE_VIDEO, Solution
from media.lexicon import HAND_COMPONENTS, SignClip

SOURCE = SOURCE_VIDEO          # reference: the reference video's landmarks (message fidelity)
LOSSLESS = LOSSLESS_RENDER     # reference: the lossless render's landmarks (codec loss of an avatar solution)
# the ceiling of each reference: its own frames, resampled by sub-pixel shifts and re-extracted (Judge.uncoded)
UNCODED_SUBJECTS = {SOURCE: "uncoded reference, resampled", LOSSLESS: "uncoded lossless render, resampled"}


class Signing(Protocol):
    """What Judge reads of a signing (pipeline.studies.shared.Scenario is one): kind ("video", "word", "pose"),
    name, fps; frames (T, H, W, 3) uint8 and labels (T, H, W) uint8 of the reference, landmarks its landmarks;
    render, render_labels, render_landmarks: the avatar's lossless render (the reference itself in the avatar
    scenarios); spans: (letter, first frame, end frame exclusive) of a fingerspelled word or None; language."""
    kind: str
    name: str
    fps: float
    frames: np.ndarray
    labels: np.ndarray
    landmarks: SignClip
    render: np.ndarray
    render_labels: np.ndarray
    render_landmarks: SignClip
    spans: list | None
    language: str | None

    @property
    def n_frames(self) -> int: ...


@dataclass
class Viewed:
    """What the viewer sees at one point: frames (T, H, W, 3) uint8 at the reference's times, the decoded skin
    mask (T, H, W) bool or None where the solution sends no skin shape, and the point's record fields."""
    frames: np.ndarray
    skin: np.ndarray | None
    fields: dict


def hold_indices(times_s: np.ndarray, fps: float, n_sent: int) -> np.ndarray:
    """(T,) for each reference frame time (seconds), the index of the sent frame on screen then: frames sent at
    the ticks 0, 1/fps, ... are held until the next tick."""
    ticks = np.floor(np.asarray(times_s, np.float64) * fps + 1e-6).astype(int)
    return np.clip(ticks, 0, n_sent - 1)


def select_frames(clip: SignClip, indices: np.ndarray, fps: float | None = None) -> SignClip:
    """The landmarks of the frames at indices (M,), in that order (repeats allowed), at fps (None: the clip's)."""
    return SignClip(clip.fps if fps is None else fps, {k: v[indices] for k, v in clip.points.items()},
                    {k: v[indices] for k, v in clip.confidence.items()})


def measured_spans(spans: list | None, step: int, n_measured: int) -> list | None:
    """Letter spans (letter, first, end exclusive) in the measured frames' indices (every step-th frame); a span
    keeps at least one measured frame."""
    if not spans:
        return None
    out = []
    for letter, start, end in spans:
        first = min(-(-start // step), n_measured - 1)
        out.append((letter, first, min(max(-(-end // step), first + 1), n_measured)))
    return out


def hand_share(clip: SignClip) -> float:
    """Share of frames (0-1) showing either hand (all 21 points)."""
    shown = np.zeros(clip.n_frames, bool)
    for component in HAND_COMPONENTS.values():
        shown |= np.all(clip.confidence[component] > 0, axis=1)
    return float(shown.mean()) if clip.n_frames else 0.0


class Judge:
    """Measures what the viewer sees against a signing's references (intelligibility, letters, image quality).

    step: intelligibility is measured on every step-th frame (`measured`, (M,) indices); recogniser: a
    comparisons.judging.letters.Recogniser for a fingerspelled word's letters (None: no letter fields)."""

    def __init__(self, signing: Signing, step: int = 1, recogniser=None):
        self.signing = signing
        self.measured = np.arange(0, signing.n_frames, max(1, step))     # (M,) frames measured
        self.reference = select_frames(signing.landmarks, self.measured)
        self.render_reference = select_frames(signing.render_landmarks, self.measured)
        self.spans = measured_spans(signing.spans, max(1, step), len(self.measured))
        self.recogniser = recogniser if signing.spans else None
        self.reference_skin = np.isin(signing.labels, SKIN_PARTS)
        self.render_skin = np.isin(signing.render_labels, SKIN_PARTS)

    def letters(self, observed: SignClip) -> dict:
        """letter_top1 / letter_top3 (percent) of a fingerspelled word's letters; {} without a word."""
        if self.recogniser is None:
            return {}
        from comparisons.judging.letters import recognise_spans, top_k
        rankings = recognise_spans(self.recogniser, observed, self.signing.language, self.spans)
        truths = [letter for letter, _, _ in self.spans]
        return {"letter_top1": top_k(rankings, truths, 1), "letter_top3": top_k(rankings, truths, 3)}

    def references(self, solution: str) -> list[tuple[str, SignClip]]:
        """The references a solution's points are measured against, at the measured frames."""
        refs = [(SOURCE, self.reference)]
        if Solution(solution).avatar:
            refs.append((LOSSLESS, self.render_reference))
        return refs

    def hands_to_extract(self, references: list[SignClip]) -> np.ndarray:
        """(M, 2) bool: at each measured frame, whether the left / right hand of what the viewer sees is read by any
        measure against these references (the measured frames' landmarks): where it signs in one of them
        (intelligibility.signing_hands), and a fingerspelled word's signing hand inside its letters' spans (the
        letters read it wherever it is found). A hand at rest or missing in every reference is read by nothing,
        so the extractor need not look for it (rest frames are scored for the face and body only)."""
        wanted = np.logical_or.reduce([signing_hands(reference) for reference in references])
        if self.recogniser is not None and self.spans:
            from comparisons.judging.letters import signing_hand
            side = list(HAND_COMPONENTS).index(signing_hand(self.signing.language))
            for _, first, end in self.spans:
                wanted[first:end, side] = True
        return wanted

    def hands_for(self, solution: str) -> np.ndarray:
        """(M, 2) bool: `hands_to_extract` of the references a solution's points are measured against."""
        return self.hands_to_extract([reference for _, reference in self.references(solution)])

    def draw_fields(self, reference: SignClip, observed: SignClip) -> dict:
        """The intelligibility, message and letter fields of one extraction (observed: the landmarks of the measured
        frames) against one reference's landmarks."""
        return {**measure(reference, observed).fields(), **message_fields(reference, observed),
                **self.letters(observed)}

    def intelligibility_draws(self, solution: str, draws: list[SignClip]) -> list[tuple[str, list[dict]]]:
        """(reference name, the fields of each extraction (`draw_fields`), in the draws' order) for each reference of
        the solution: what `intelligibility` averages, kept so that later extractions can be added to them."""
        letters = [self.letters(observed) for observed in draws]
        return [(name, [{**measure(reference, observed).fields(), **message_fields(reference, observed), **letter}
                        for observed, letter in zip(draws, letters)])
                for name, reference in self.references(solution)]

    def intelligibility(self, solution: str, draws: list[SignClip]) -> list[tuple[str, dict]]:
        """(reference name, intelligibility and letter fields, each the mean over the draws, with their spread) for
        each reference of the solution; draws: the landmarks of the measured frames, one SignClip per extraction."""
        return [(name, mean_fields(fields)) for name, fields in self.intelligibility_draws(solution, draws)]

    def quality(self, solution: str, viewed: Viewed) -> dict:
        """Image quality of what the viewer sees against the frames the solution codes (the lossless render for an
        avatar solution, else the reference; skin: the union of the reference's and the decoded skin mask)."""
        s = self.signing
        avatar = Solution(solution).avatar
        reference_frames = s.render if avatar else s.frames
        reference_skin = self.render_skin if avatar else self.reference_skin
        skin = reference_skin if viewed.skin is None else reference_skin | viewed.skin
        return image_quality.quality_fields(reference_frames, viewed.frames, skin)

    def records(self, solution: str, viewed: Viewed, draws: list[SignClip]) -> list[dict]:
        """One record per reference of the solution, each with the point's fields, image quality (`quality`) and
        intelligibility (draws: the landmarks of what the viewer sees, one SignClip per extraction)."""
        quality = self.quality(solution, viewed)
        return [dict(viewed.fields, **quality, reference=name, **fields)
                for name, fields in self.intelligibility(solution, draws)]

    def uncoded_draws(self, resampled_source: list[SignClip], resampled_render: list[SignClip]
                      ) -> list[tuple[dict, list[dict]]]:
        """The ceilings of `uncoded`, each as (its record's identifying fields, the fields of each extraction)."""
        s = self.signing
        source, render = self.reference, self.render_reference
        subjects = [(UNCODED_SUBJECTS[SOURCE], SOURCE, source, resampled_source),
                    (UNCODED_SUBJECTS[LOSSLESS], LOSSLESS, render, resampled_render)]
        if s.kind == "video":
            subjects.append(("uncoded lossless render", SOURCE, source, [render]))
        return [({"kind": "uncoded", "subject": subject, "clip": s.name, "reference": name, "fps": s.fps},
                 [self.draw_fields(reference, observed) for observed in draws])
                for subject, name, reference, draws in subjects]

    def uncoded(self, resampled_source: list[SignClip], resampled_render: list[SignClip]) -> list[dict]:
        """The ceilings ("uncoded" records): each reference's measured frames re-extracted under the same sub-pixel
        shifts as every point (resampled_source, resampled_render: one SignClip per extraction; invisible shifts,
        but new pixels: the landmark extractor's own noise floor), against the reference's landmarks, the mean over
        the draws; and (video scenario) the lossless render's landmarks against the source video's (the
        retargeting loss alone)."""
        return [dict(head, **mean_fields(fields)) for head, fields in self.uncoded_draws(resampled_source,
                                                                                          resampled_render)]


def distinct_frames(frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(first, inverse): the indices (D,) of the first of each run of byte-identical frames in frames (T, ...), in
    order of first appearance, and for every frame (T,) the position in first of its picture, so that
    frames[first][inverse] equals frames. A picture held on screen, or decoded identical to one already shown, is
    extracted once."""
    seen: dict[bytes, int] = {}
    first, inverse = [], np.empty(len(frames), int)
    for t, frame in enumerate(frames):
        key = hashlib.blake2b(np.ascontiguousarray(frame).tobytes(), digest_size=16).digest()
        if key not in seen:
            seen[key] = len(first)
            first.append(t)
        inverse[t] = seen[key]
    return np.asarray(first, int), inverse
