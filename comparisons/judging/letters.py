"""Which letter a fingerspelling hand shows: a nearest-template recogniser on normalised hand landmarks.

Features (`normalise_hand`): the hand's 21 points in the image plane (x, y; depth is flattened in the
lexicon and not comparable across renders), a left hand mirrored to a right one (x -> -x), the wrist
moved to the origin and divided by the hand size of comparisons.judging.intelligibility.hand_sizes (palm-based,
so a fist is not blown up). The orientation in the image is KEPT by default (orientation 'image'): in
fingerspelling alphabets some letters differ mainly by it (ASL H/U, G/Q, K/P). Measured
(benchmarks/letter_recognition.py, all 20 languages, half-span templates of the same clip): rotating
hands upright ('upright') is a tie on the lexicon (top-1 90.6 % against 90.1 %; from other languages'
clips only 36.2 % against 37.3 %), but worse across the avatar's domain gap (ASL alphabet rendered and
re-extracted: top-1 69 % against 77 %), so the image orientation is the default.

Distance of a frame to a template: the mean over the 21 points of the Euclidean distance, in hand sizes.
A letter's distance is the smallest over its templates; a span's is the mean over its frames that show
the signing hand; letters are ranked by it, nearest first.

Templates (`Recogniser.from_lexicon`): every frame of a lexicon clip's held span
(media.fingerspelling.held_span: the hand neither rising into place nor dropping away) in which the
language's signing hand is seen, keyed by (language, letter). A letter is named by its lexicon unit
(media.lexicon.normalize_unit, so 'a' and 'A' are one letter). Ranking for a language considers exactly
that language's alphabet; a letter's templates come from every template language whose alphabet has a
letter of that name, so other signers' handshapes of the same letter count (most of the lexicon's
alphabets derive from the French one and share handshapes; where they do not, another language's
template of that name is simply a worse or misleading template). `exclude` leaves (language, letter)
clips out, `half` keeps only the first or second half of each held span: together they keep the scored
frames out of the templates. The lexicon has one signer per language, so a template from the scored
language's own clip is the same person, the same take.

Signing hand: the language's only signing hand (lexicon.signing_hands: Italian left, most right); in the
two-handed alphabets (Czech, Croatian, Turkish) the right, dominant hand; the other hand is not used.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from comparisons.judging.intelligibility import hand_sizes
from media import lexicon
from media.errors import SigncastError
from media.fingerspelling import held_span
from media.lexicon import HAND_COMPONENTS, SignClip, normalize_unit

ORIENTATIONS = ("image", "upright")


def normalise_hand(points: np.ndarray, hand: str, orientation: str = "image") -> np.ndarray:
    """Hand landmarks (..., 21, >=2) pixels -> (..., 21, 2) in hand sizes, wrist at the origin, as a right hand.

    orientation 'image' keeps the hand's direction in the image; 'upright' rotates wrist -> middle MCP to
    point up (-y), which makes the features rotation-invariant.
    """
    if hand not in HAND_COMPONENTS:
        raise SigncastError(f"unknown hand {hand!r}: choose left or right")
    if orientation not in ORIENTATIONS:
        raise SigncastError(f"unknown orientation {orientation!r}: choose one of {', '.join(ORIENTATIONS)}")
    points = np.asarray(points, np.float64)[..., :2]
    centred = points - points[..., :1, :]
    if hand == "left":
        centred = centred * np.array([-1.0, 1.0])
    centred = centred / np.maximum(hand_sizes(points), 1e-9)[..., None, None]
    if orientation == "upright":
        direction = centred[..., 9, :]
        angle = np.arctan2(direction[..., 0], -direction[..., 1])          # 0 when pointing up
        cos, sin = np.cos(angle)[..., None], np.sin(angle)[..., None]
        x, y = centred[..., 0], centred[..., 1]
        centred = np.stack([cos * x + sin * y, cos * y - sin * x], axis=-1)   # rotated by -angle
    return centred


@functools.lru_cache(maxsize=64)
def signing_hand(language: str) -> str:
    """The hand that forms a language's letters: its only signing hand, or the right one of two."""
    hands = lexicon.signing_hands(language)
    return hands[0] if len(hands) == 1 else "right"


@functools.lru_cache(maxsize=64)
def _alphabet(language: str) -> tuple[tuple[str, str], ...]:
    """(letter key, unit as written) of a language's lexicon units, in lexicon order."""
    return tuple((normalize_unit(unit), unit) for unit in lexicon.units(language))


@functools.lru_cache(maxsize=1024)
def _held_hand(entry: lexicon.LexiconEntry, hand: str) -> tuple[int, int, np.ndarray, np.ndarray]:
    """A lexicon clip's held span [start, stop), its `hand` points (T, 21, 3) and the frames that show it."""
    clip = lexicon.read_clip(entry)
    start, stop = held_span(clip)
    component = HAND_COMPONENTS[hand]
    return start, stop, clip.points[component], np.flatnonzero(np.all(clip.confidence[component] > 0, axis=1))


@dataclass
class Recogniser:
    """Templates: features (M, 21, 2) hand sizes, and for each its (language, letter key) and source frame."""
    features: np.ndarray
    keys: list[tuple[str, str]]
    frames: list[int]
    orientation: str = "image"

    def __post_init__(self) -> None:
        letters = np.array([key for _, key in self.keys])
        self._order = np.argsort(letters, kind="stable")
        keys, starts = np.unique(letters[self._order], return_index=True)
        self._letter_keys, self._starts = keys.tolist(), starts
        # (21, M) x and y, templates in letter order: contiguous rows for the distance loop
        ordered = np.asarray(self.features, np.float64)[self._order]
        self._x, self._y = np.ascontiguousarray(ordered[..., 0].T), np.ascontiguousarray(ordered[..., 1].T)

    @classmethod
    def from_lexicon(cls, languages: list[str], letters: list[str] | None = None,
                     exclude: set[tuple[str, str]] = frozenset(), half: int | None = None,
                     orientation: str = "image") -> "Recogniser":
        """Templates from the held spans of the lexicon clips of `languages`.

        letters: only these letters (any case; None: all). exclude: (language, letter) clips to leave out.
        half: None every held frame, 0 the first half of each held span, 1 the second half (a span of n
        frames splits at n // 2). orientation: see normalise_hand.
        """
        wanted = None if letters is None else {normalize_unit(letter) for letter in letters}
        # the same file may stand for letters of two languages (the lexicon's fsl clips are its ase clips):
        # a clip is left out by its file, and used once
        used = {lexicon.lookup(language, letter).path for language, letter in exclude}
        features, keys, frames, sources = [], [], [], set()
        for language in languages:
            language = lexicon.check_language(language)
            hand = signing_hand(language)
            for entry in lexicon.entries(language):
                key = normalize_unit(entry.unit)
                if (wanted is not None and key not in wanted) or entry.path in used:
                    continue
                used.add(entry.path)
                sources.add(entry.path)
                start, stop, points, seen = _held_hand(entry, hand)
                if half is not None:
                    middle = start + (stop - start) // 2
                    start, stop = (start, middle) if half == 0 else (middle, stop)
                seen = seen[(seen >= start) & (seen < stop)]
                if not len(seen):
                    continue
                features.append(normalise_hand(points[seen], hand, orientation))
                keys += [(language, key)] * len(seen)
                frames += seen.tolist()
        if not features:
            raise SigncastError("no letter templates: no held frame shows the signing hand in the chosen clips")
        recogniser = cls(np.concatenate(features), keys, frames, orientation)
        recogniser._sources = frozenset(sources)
        return recogniser

    @classmethod
    def other_signers(cls, language: str, orientation: str = "image") -> "Recogniser":
        """Templates from other signers only: every other language's clips, leaving out by file every clip of
        `language` (the lexicon has one signer per language, and its fsl clips are the ase files: a language's files
        are its signer's, and the recordings the avatar replays for it are among them)."""
        language = lexicon.check_language(language)
        own = {(language, entry.unit) for entry in lexicon.entries(language)}
        others = [other for other in lexicon.languages() if other != language]
        return cls.from_lexicon(others, exclude=own, orientation=orientation)

    def sources(self) -> set:
        """The lexicon files the templates were taken from (set by from_lexicon)."""
        return set(getattr(self, "_sources", ()))

    @classmethod
    def joined(cls, recognisers: list["Recogniser"]) -> "Recogniser":
        """One recogniser holding the templates of all of `recognisers` (same orientation)."""
        orientations = {recogniser.orientation for recogniser in recognisers}
        if len(orientations) != 1:
            raise SigncastError(f"cannot join recognisers of orientations {sorted(orientations)}")
        return cls(np.concatenate([recogniser.features for recogniser in recognisers]),
                   [key for recogniser in recognisers for key in recogniser.keys],
                   [frame for recogniser in recognisers for frame in recogniser.frames], orientations.pop())

    def letter_distances(self, hand_points: np.ndarray, hand: str,
                         language: str | None = None) -> tuple[list[str], np.ndarray]:
        """Letters and each frame's distance to them (hand sizes): (letters, (T, L)) for points (T, 21, >=2).

        Letters: `language`'s units that have a template (None: every letter key with one).
        """
        hand_points = np.asarray(hand_points, np.float64)
        if hand_points.ndim != 3 or hand_points.shape[1] != 21:
            raise SigncastError(f"hand landmarks must be (frames, 21, 2 or 3), not {hand_points.shape}")
        query = normalise_hand(hand_points, hand, self.orientation)
        # (T, M): mean over the 21 points of the point distance, templates in letter order
        distances = np.zeros((len(query), len(self.features)))
        for point in range(21):
            dx = query[:, point, 0, None] - self._x[point]
            dy = query[:, point, 1, None] - self._y[point]
            distances += np.sqrt(dx * dx + dy * dy)
        distances /= 21
        per_key = np.minimum.reduceat(distances, self._starts, axis=1)
        column = {key: index for index, key in enumerate(self._letter_keys)}
        if language is None:
            names = written = list(self._letter_keys)
        else:
            pairs = [(key, unit) for key, unit in _alphabet(lexicon.check_language(language)) if key in column]
            names, written = [key for key, _ in pairs], [unit for _, unit in pairs]
        per_letter = per_key[:, [column[key] for key in names]]
        return written, per_letter

    def rank(self, hand_points: np.ndarray, hand: str, language: str | None = None) -> list[str]:
        """Letters for one hand (21, 2 or 3) pixels, nearest first (see letter_distances for which letters)."""
        letters, distances = self.letter_distances(np.asarray(hand_points)[None], hand, language)
        return [letters[index] for index in np.argsort(distances[0], kind="stable")]


def recognise_spans(recogniser: Recogniser, clip: SignClip, language: str,
                    spans: list[tuple[str, int, int]]) -> list[list[str]]:
    """For each known letter span (letter, first frame, end frame exclusive) of `clip`, the letters of
    `language` ranked by their mean distance over the span's frames that show the language's signing hand;
    an empty list where no frame of the span shows it (a miss for top_k)."""
    hand = signing_hand(lexicon.check_language(language))
    component = HAND_COMPONENTS[hand]
    seen = np.all(clip.confidence[component] > 0, axis=1)
    rankings = []
    for _, start, stop in spans:
        if not 0 <= start < stop <= clip.n_frames:
            raise SigncastError(f"letter span {start}..{stop} is outside the clip's {clip.n_frames} frames")
        frames = np.flatnonzero(seen[start:stop]) + start
        if not len(frames):
            rankings.append([])
            continue
        letters, distances = recogniser.letter_distances(clip.points[component][frames], hand, language)
        rankings.append([letters[index] for index in np.argsort(distances.mean(axis=0), kind="stable")])
    return rankings


def top_k(rankings: list[list[str]], truths: list[str], k: int) -> float:
    """Percent of rankings whose first k letters hold the true letter (compared as lexicon units)."""
    if len(rankings) != len(truths) or not truths:
        raise SigncastError(f"top-k needs one ranking per true letter: {len(rankings)} rankings, {len(truths)} letters")
    hits = sum(normalize_unit(truth) in {normalize_unit(letter) for letter in ranking[:k]}
               for ranking, truth in zip(rankings, truths))
    return 100.0 * hits / len(truths)
