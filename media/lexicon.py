"""The fingerspelling lexicon of the `spoken-to-signed` package: real signers' letters as keypoints.

`index.csv` lists 626 clips (columns path, spoken_language, signed_language, start, end, words,
glosses, priority) in 20 sign languages; each clip is a `.pose` file of MediaPipe Holistic
keypoints (components POSE_LANDMARKS 33, FACE_LANDMARKS 478, LEFT_HAND_LANDMARKS 21,
RIGHT_HAND_LANDMARKS 21, POSE_WORLD_LANDMARKS 33) read with `pose-format`.

What the data is (measured over all clips): coordinates are pixels of a 500x500 frame (x right,
y down; points may lie outside it); the depth channel was flattened by the package's
preprocessing (std ~0.01 over a hand), so the keypoints are effectively 2D; frame rates are 25,
29.97 and 30 fps (one Greek clip at 24); points MediaPipe did not see are masked (confidence 0
here). The `start`/`end` columns (ms) refer to the source videos: start is always 0 and end
always exceeds the clip's duration, so the clips are already cut; `read_clip` still honours them.
Most languages sign with the right hand only, Italian (ise) with the left only, Czech, Croatian
and Turkish (cse, csq, tsm) use both. The French (fsl) clips are the very same `.pose` files as the ASL (ase) ones,
all 26 letters: fsl is not another signer (comparisons.judging.letters leaves clips out by file). The package is located, never imported, and nothing is
downloaded.
"""
from __future__ import annotations

import csv
import functools
import importlib.util
import unicodedata
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from media.errors import SigncastError

HAND_COMPONENTS = {"left": "LEFT_HAND_LANDMARKS", "right": "RIGHT_HAND_LANDMARKS"}
POSE_COMPONENT = "POSE_LANDMARKS"
POSE_POINTS = ("NOSE", "LEFT_EYE_INNER", "LEFT_EYE", "LEFT_EYE_OUTER", "RIGHT_EYE_INNER", "RIGHT_EYE",
               "RIGHT_EYE_OUTER", "LEFT_EAR", "RIGHT_EAR", "MOUTH_LEFT", "MOUTH_RIGHT", "LEFT_SHOULDER",
               "RIGHT_SHOULDER", "LEFT_ELBOW", "RIGHT_ELBOW", "LEFT_WRIST", "RIGHT_WRIST", "LEFT_PINKY",
               "RIGHT_PINKY", "LEFT_INDEX", "RIGHT_INDEX", "LEFT_THUMB", "RIGHT_THUMB", "LEFT_HIP",
               "RIGHT_HIP")


@dataclass(frozen=True)
class LexiconEntry:
    """One row of index.csv. start_ms/end_ms: the cut in the clip's time line, milliseconds."""
    signed_language: str
    spoken_language: str
    unit: str
    gloss: str
    path: Path
    start_ms: float
    end_ms: float
    priority: int


@dataclass
class SignClip:
    """Keypoints of one clip.

    fps: frames per second. points: component name -> (T, N, 3) float64 (x, y pixels, right/down;
    z the flattened depth). confidence: component name -> (T, N) float64 in [0, 1], 0 where the
    point is masked (its coordinates are then 0, never NaN).
    """
    fps: float
    points: dict[str, np.ndarray]
    confidence: dict[str, np.ndarray]
    entry: LexiconEntry | None = None

    @property
    def n_frames(self) -> int:
        return len(next(iter(self.points.values())))

    def hand_visibility(self, hand: str) -> float:
        """Share of frames in which all 21 points of `hand` ('left'/'right') were seen."""
        confidence = self.confidence.get(HAND_COMPONENTS[hand])
        if confidence is None or not len(confidence):
            return 0.0
        return float(np.mean(np.all(confidence > 0, axis=1)))


def lexicon_dir() -> Path:
    """Folder of the bundled lexicon inside the installed `spoken_to_signed` package."""
    spec = importlib.util.find_spec("spoken_to_signed")
    if spec is None or not spec.submodule_search_locations:
        raise SigncastError("the spoken-to-signed package is not installed: pip install spoken-to-signed")
    folder = Path(list(spec.submodule_search_locations)[0]) / "assets" / "fingerspelling_lexicon"
    if not (folder / "index.csv").is_file():
        raise SigncastError(f"fingerspelling lexicon index not found at {folder / 'index.csv'}")
    return folder


def normalize_unit(text: str) -> str:
    """Case-insensitive key for a letter or word: NFC, lower case, Greek final sigma as sigma."""
    return unicodedata.normalize("NFC", text).lower().replace("ς", "σ")


@functools.lru_cache(maxsize=1)
def load_index() -> tuple[LexiconEntry, ...]:
    """All rows of index.csv, in file order."""
    folder = lexicon_dir()
    entries = []
    with (folder / "index.csv").open(newline="", encoding="utf-8") as index_file:
        for row in csv.DictReader(index_file):
            entries.append(LexiconEntry(
                signed_language=row["signed_language"], spoken_language=row["spoken_language"],
                unit=unicodedata.normalize("NFC", row["words"]), gloss=row["glosses"],
                path=folder / row["path"], start_ms=float(row["start"] or 0), end_ms=float(row["end"] or 0),
                priority=int(row["priority"] or 0)))
    return tuple(entries)


def languages() -> list[str]:
    """Signed-language codes present in the lexicon (ISO 639-3, e.g. 'ase'), sorted."""
    return sorted({entry.signed_language for entry in load_index()})


def check_language(language: str) -> str:
    """The language code as stored, or SigncastError naming the languages that exist."""
    available = languages()
    if language in available:
        return language
    lowered = {code.lower(): code for code in available}
    if language.lower() in lowered:
        return lowered[language.lower()]
    raise SigncastError(f"unknown sign language {language!r}; the lexicon has: {', '.join(available)}")


def entries(language: str) -> list[LexiconEntry]:
    """The language's entries in file order; for a unit listed twice, the lower priority value wins."""
    language = check_language(language)
    chosen: dict[str, LexiconEntry] = {}
    for entry in load_index():
        if entry.signed_language != language:
            continue
        key = normalize_unit(entry.unit)
        if key not in chosen or entry.priority < chosen[key].priority:
            chosen[key] = entry
    return list(chosen.values())


def units(language: str) -> list[str]:
    """The letters / multi-letter units of a language, as written in the lexicon."""
    return [entry.unit for entry in entries(language)]


def lookup(language: str, unit: str) -> LexiconEntry:
    """The entry for one unit (case-insensitive), or SigncastError naming the units that exist."""
    key = normalize_unit(unit)
    for entry in entries(language):
        if normalize_unit(entry.unit) == key:
            return entry
    raise SigncastError(f"no letter {unit!r} in the {check_language(language)} lexicon; "
                        f"it has: {' '.join(units(language))}")


def split_word(language: str, word: str) -> list[str]:
    """Split `word` into the language's units, longest match first, case-insensitively.

    Whitespace is kept as the unit " " (a pause); an accented letter the lexicon lacks is spelled as
    its base letter (Greek tonos: ό -> Ο) when that exists (substitutions lists them, for a notice). Returns units
    as written in the lexicon, e.g. ssp "LLAMA" -> ["LL", "A", "M", "A"]; a character no unit covers raises
    SigncastError.
    """
    return _split(language, word)[0]


def substitutions(language: str, word: str) -> list[tuple[str, str]]:
    """(letter as written, unit it is spelled as) for each accented letter of word outside the language's alphabet
    that split_word spells as its base letter, e.g. ase "HÉLLO" -> [("É", "E")]; each pair once."""
    return list(dict.fromkeys(_split(language, word)[1]))


def _split(language: str, word: str) -> tuple[list[str], list[tuple[str, str]]]:
    table = {normalize_unit(entry.unit): entry.unit for entry in entries(language)}
    longest = max(len(key) for key in table)
    written = unicodedata.normalize("NFC", word.strip())
    text = normalize_unit(written)
    if not text:
        raise SigncastError("nothing to fingerspell: the word is empty")
    result: list[str] = []
    mapped: list[tuple[str, str]] = []
    position = 0
    while position < len(text):
        if text[position].isspace():
            if result and result[-1] != " ":
                result.append(" ")
            position += 1
            continue
        for size in range(min(longest, len(text) - position), 0, -1):
            piece = text[position:position + size]
            if piece in table:
                result.append(table[piece])
                position += size
                break
        else:
            # a letter with an accent the lexicon lacks (Greek tonos, French acute) is spelled as its base letter
            base = unicodedata.normalize("NFD", text[position])[0]
            if base != text[position] and base in table:
                result.append(table[base])
                mapped.append((written[position] if len(written) == len(text) else text[position], table[base]))
                position += 1
                continue
            # quote the letter as the user wrote it (Greek capitals too), unless lower-casing changed the length
            letter = written[position] if len(written) == len(text) else text[position]
            raise SigncastError(f"cannot fingerspell {word!r} in {check_language(language)}: no letter "
                                f"{letter!r}; the lexicon has: {' '.join(units(language))}")
    return result, mapped


def read_clip(entry: LexiconEntry) -> SignClip:
    """Keypoints of one lexicon entry, cut to [start_ms, end_ms) where that is inside the clip."""
    from media.pose_file import read_pose  # imports pose-format, heavy: only when a clip is read

    clip = read_pose(entry.path)
    fps = clip.fps
    times_ms = np.arange(clip.n_frames) * 1000.0 / fps
    keep = times_ms >= entry.start_ms
    if entry.end_ms > entry.start_ms:
        keep &= times_ms < entry.end_ms
    if not keep.any():
        keep[:] = True
    return SignClip(fps, {name: points[keep] for name, points in clip.points.items()},
                    {name: confidence[keep] for name, confidence in clip.confidence.items()}, entry)


def signing_hands(language: str, threshold: float = 0.3) -> list[str]:
    """Hands ('left', 'right') that sign in the language: seen in >= threshold of the frames of its clips."""
    counts = {"left": [], "right": []}
    for entry in entries(language):
        clip = read_clip(entry)
        for hand in counts:
            counts[hand].append(clip.hand_visibility(hand))
    return [hand for hand, shares in counts.items() if np.mean(shares) >= threshold]
