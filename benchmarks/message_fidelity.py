"""Message fidelity on real signing: every lexicon clip against the avatar's render of it (issue 34, section 4).

For each clip of the fingerspelling lexicon (media.lexicon; real signers' MediaPipe Holistic keypoints, 500x500
pixel frames), at the clip's own frame rate and frame count:

1. the clip is retargeted to the avatar as the lexicon always is (media.retarget.retarget, its lexicon defaults),
2. rendered shaded (media.render) at --size, framed (--framing) like the clip's signer ("source", the default:
   pipeline.studies.shared.pose_framing, as `signcast render --pose` frames it: one zoom and shift of the camera
   fitted on shoulders and face in the clip's 500x500 frame, corrected by reading a dozen framed frames back) or as
   the full figure ("full-figure": the signing-space camera); a clip the framing cannot fit is rendered full figure
   and its row says so,
3. the render's landmarks are extracted with the extractor `signcast pose` uses (media.landmarks.holistic),
4. comparisons.judging.fidelity compares the clip's own landmarks (the reference) with the extracted ones:
   per hand the source shows in at least MIN_HAND_SHARE of its frames (the hands retargeting drives): found
   (percent of the frames the source shows the hand in which the render's hand is found too), oriented handshape
   PCK@0.2 and error (hand sizes), shape-only PCK, wrist location and movement (shoulder widths, after one
   clip-wide similarity on torso and face); face (mouth, eyes: interocular distances).
5. letter recognition (comparisons.judging.letters, image orientation): the clip's held span
   (media.fingerspelling.held_span, the same frames in the render) ranked among the language's letters with
   templates of other signers only (Recogniser.other_signers: every other language's clips, every file of this
   language left out), once on the clip's own landmarks and once on the render's; the avatar's penalty is the
   difference of the top-1 rates in points.

One row per clip streams into OUT/clips.jsonl (a rerun with the same --out and --size skips the clips already
there); at the end OUT/clips.csv, OUT/languages.csv and OUT/summary.md hold the per-clip rows, the per-language
table (medians over clips) and the summary with the worst clips. The lexicon's fsl clips are its ase files: they
are measured once and listed under both languages; the "all" row counts each file once.

    .venv/bin/python benchmarks/message_fidelity.py --out /tmp/fidelity [--languages ase gsg] [--limit 10]
        [--size 500x500] [--framing source|full-figure] [--jobs 2] [--report]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from media.errors import SigncastError  # noqa: E402

SIDES = {"left": "L", "right": "R"}
HAND_METRICS = ("found", "pck", "error", "shape_pck", "location", "movement")
TARGETS = {"found": 97.0, "pck_median": 97.0, "pck_every_clip": 85.0, "location_median": 0.05, "letter_penalty": 5.0}
_WORKER: dict = {}


def _renderer(size: tuple[int, int], framing=None):
    """The avatar and a shaded renderer at size (width, height) with a media.framing.Framing (None: the full-figure
    renderer, made once per process)."""
    from media.avatar import load_avatar
    from media.render import AvatarRenderer, RenderSettings
    if "avatar" not in _WORKER:
        _WORKER["avatar"] = load_avatar()
    avatar = _WORKER["avatar"]
    if framing is not None:
        return avatar, AvatarRenderer(avatar, RenderSettings(size[0], size[1], look="shaded", framing=framing))
    if size not in _WORKER:
        _WORKER[size] = AvatarRenderer(avatar, RenderSettings(size[0], size[1], look="shaded"))
    return avatar, _WORKER[size]


def _mean(values) -> float | None:
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def measure_clip(job: tuple[str, str, tuple[int, int], str]) -> dict:
    """One clip (language, unit, (width, height), framing 'source' or 'full-figure') -> its row: the hands' metrics
    averaged over the hands the source shows in at least MIN_HAND_SHARE of its frames (units as in the module
    docstring), per-hand values under 'left_'/'right_', face, held span, and the extracted landmarks of both hands
    for letter scoring ('observed': component -> (points (T, 21, 3) pixels, confidence (T, 21)); removed before the
    row is written)."""
    from comparisons.judging import fidelity
    from media import lexicon
    from media.fingerspelling import held_span
    from media.landmarks.holistic import extract_landmarks
    from media.retarget import MIN_HAND_SHARE, retarget

    language, unit, size, framing_name = job
    entry = lexicon.lookup(language, unit)
    source = lexicon.read_clip(entry)
    avatar, _ = _renderer(tuple(size))
    started = time.perf_counter()
    motion = retarget(source, avatar.skeleton).motion
    retarget_s = time.perf_counter() - started
    started = time.perf_counter()
    framing = None
    if framing_name == "source":
        from pipeline.studies.shared import pose_framing
        framing = pose_framing(entry.path, motion, tuple(size))
    framing_s = time.perf_counter() - started
    _, renderer = _renderer(tuple(size), framing)
    started = time.perf_counter()
    frames = np.stack([rgb for rgb, _ in renderer.frames(motion)])
    render_s = time.perf_counter() - started
    started = time.perf_counter()
    observed = extract_landmarks(iter(frames), source.fps, n_frames=len(frames))
    extract_s = time.perf_counter() - started

    metrics = fidelity.message_fidelity(source, observed)
    hands = [hand for hand in SIDES if source.hand_visibility(hand) >= MIN_HAND_SHARE]
    row = {"language": language, "unit": entry.unit, "file": entry.path.name, "frames": source.n_frames,
           "fps": source.fps, "width": size[0], "height": size[1], "hands": hands,
           "framing": "full-figure" if framing is None else "source",
           "zoom": None if framing is None else float(framing.scale)}
    for hand in SIDES:
        component = lexicon.HAND_COMPONENTS[hand]
        source_shown = np.all(source.confidence[component] > 0, axis=1)
        observed_shown = np.all(observed.confidence[component] > 0, axis=1)
        for key in ("found", "pck", "error", "shape_pck", "shape_error", "location", "location_p90", "movement"):
            row[f"{hand}_{key}"] = metrics[f"{hand}_{key}"]
        row[f"{hand}_source_frames"] = int(source_shown.sum())
        row[f"{hand}_both_frames"] = int((source_shown & observed_shown).sum())
    for key in HAND_METRICS:
        row[key] = _mean(row[f"{hand}_{key}"] for hand in hands)
    # found pooled over the driven hands' frames (a hand shown in more frames weighs more)
    shown = sum(row[f"{hand}_source_frames"] for hand in hands)
    row["found"] = 100.0 * sum(row[f"{hand}_both_frames"] for hand in hands) / shown if shown else None
    row["mouth_error"], row["eyes_error"] = metrics["mouth_error"], metrics["eyes_error"]
    row["held"] = list(held_span(source))
    row["seconds"] = {"retarget": retarget_s, "framing": framing_s, "render": render_s, "extract": extract_s}
    row["observed"] = {component: (observed.points[component], observed.confidence[component])
                       for component in lexicon.HAND_COMPONENTS.values()}
    return row


_RECOGNISERS: dict = {}


def _no_setup() -> None:
    """Pool workers need no setup beyond StudyPool's own (one LiteRT thread each)."""


def letter_result(row: dict) -> dict:
    """Top-3 letters of the clip's held span on its own landmarks ('real') and on the render's ('avatar'), templates
    of other signers only (Recogniser.other_signers, image orientation); empty where the span shows no signing hand."""
    from comparisons.judging.letters import Recogniser, recognise_spans
    from media import lexicon
    from media.lexicon import SignClip

    language = row["language"]
    if language not in _RECOGNISERS:
        _RECOGNISERS[language] = Recogniser.other_signers(language)
    recogniser = _RECOGNISERS[language]
    source = lexicon.read_clip(lexicon.lookup(language, row["unit"]))
    observed = SignClip(source.fps, {c: p for c, (p, _) in row["observed"].items()},
                        {c: s for c, (_, s) in row["observed"].items()})
    span = [(row["unit"], row["held"][0], row["held"][1])]
    real = recognise_spans(recogniser, source, language, span)[0]
    avatar = recognise_spans(recogniser, observed, language, span)[0]
    key = lexicon.normalize_unit(row["unit"])
    return {"real_top3": real[:3], "avatar_top3": avatar[:3],
            "real_top1": bool(real) and lexicon.normalize_unit(real[0]) == key,
            "avatar_top1": bool(avatar) and lexicon.normalize_unit(avatar[0]) == key}


# ----------------------------------------------------------------------------------------------- tables

COLUMNS = (("clips", "clips"), ("found", "both hands found %"), ("pck", "PCK@0.2 oriented %"),
           ("error", "error (hand sizes)"), ("shape_pck", "shape-only PCK %"), ("location", "wrist (shoulder widths)"),
           ("movement", "movement (sw/frame)"), ("mouth_error", "mouth (IOD)"), ("eyes_error", "eyes (IOD)"),
           ("pck85", "clips PCK >= 85 %"), ("lettered", "letters scored"), ("real_top1", "letter top-1 real %"),
           ("avatar_top1", "letter top-1 avatar %"), ("penalty", "penalty (points)"))


def _median(rows: list[dict], key: str) -> float | None:
    values = [row[key] for row in rows if row.get(key) is not None]
    return float(np.median(values)) if values else None


def summarise(rows: list[dict]) -> dict:
    """Medians over clips of every metric (found also as a mean), the share of clips with oriented PCK >= 85 % and
    the lowest, the letter top-1 rates (percent of the clips scored: those whose own landmarks get a ranking) and
    the penalty in points (real - avatar)."""
    result = {"clips": len(rows)}
    for key, _ in COLUMNS[1:9]:
        result[key] = _median(rows, key)
    scored = [row for row in rows if row.get("pck") is not None]
    result["pck85"] = 100.0 * sum(row["pck"] >= TARGETS["pck_every_clip"] for row in scored) / len(scored) \
        if scored else None
    result["pck_min"] = min((row["pck"] for row in scored), default=None)
    found = [row["found"] for row in rows if row.get("found") is not None]
    result["found_mean"] = float(np.mean(found)) if found else None
    # a clip is scored where other signers' templates rank its language's letters on its own landmarks: Greek,
    # Arabic and Cyrillic letters have none (no other language writes them so), nor has a span without the hand
    lettered = [row for row in rows if row.get("real_top3")]
    result["lettered"] = len(lettered)
    if lettered:
        result["real_top1"] = 100.0 * sum(row["real_top1"] for row in lettered) / len(lettered)
        result["avatar_top1"] = 100.0 * sum(row["avatar_top1"] for row in lettered) / len(lettered)
        result["penalty"] = result["real_top1"] - result["avatar_top1"]
    else:
        result["real_top1"] = result["avatar_top1"] = result["penalty"] = None
    return result


def table(rows: list[dict]) -> list[tuple[str, dict]]:
    """(language, summary) per language in lexicon order, then ('all', summary) over distinct files."""
    languages = sorted({row["language"] for row in rows})
    lines = [(language, summarise([row for row in rows if row["language"] == language])) for language in languages]
    distinct = list({row["file"]: row for row in rows}.values())
    return lines + [("all", summarise(distinct))]


def _cell(value, key: str) -> str:
    if value is None:
        return "-"
    if key in ("clips", "lettered"):
        return str(value)
    return f"{value:.3f}" if key in ("error", "location", "movement", "mouth_error", "eyes_error") else f"{value:.1f}"


def markdown(lines: list[tuple[str, dict]]) -> str:
    head = "| language | " + " | ".join(name for _, name in COLUMNS) + " |"
    rule = "|---" * (len(COLUMNS) + 1) + "|"
    body = ["| " + language + " | " + " | ".join(_cell(summary.get(key), key) for key, _ in COLUMNS) + " |"
            for language, summary in lines]
    return "\n".join([head, rule] + body)


def worst(rows: list[dict], count: int = 10) -> str:
    """The count clips of lowest oriented PCK, as a markdown table."""
    scored = sorted((row for row in rows if row.get("pck") is not None), key=lambda row: row["pck"])
    seen, chosen = set(), []
    for row in scored:
        if row["file"] not in seen:
            seen.add(row["file"])
            chosen.append(row)
    lines = ["| clip | hands | found % | PCK % | shape PCK % | wrist (sw) | letter real / avatar |",
             "|---|---|---|---|---|---|---|"]
    for row in chosen[:count]:
        letters = (f"{''.join(row['real_top3'][:1]) or '-'} / {''.join(row['avatar_top3'][:1]) or '-'}"
                   if "real_top3" in row else "-")
        lines.append(f"| {row['language']} {row['unit']} | {'+'.join(row['hands'])} | {_cell(row['found'], 'found')} | "
                     f"{_cell(row['pck'], 'pck')} | {_cell(row['shape_pck'], 'pck')} | "
                     f"{_cell(row['location'], 'location')} | {letters} |")
    return "\n".join(lines)


def targets_text(summary: dict) -> str:
    """The issue's targets against the 'all' summary, one line each."""
    def say(name, value, target, unit, better):
        if value is None:
            return f"- {name}: not measured"
        met = value >= target if better == "high" else value <= target
        return f"- {name}: {value:.3f}{unit} against {target}{unit}: {'met' if met else 'not met'}" \
            if unit == " sw" else f"- {name}: {value:.1f}{unit} against {target}{unit}: {'met' if met else 'not met'}"
    return "\n".join([
        say("both hands found (median over clips)", summary["found"], TARGETS["found"], " %", "high"),
        say("both hands found (mean over clips)", summary["found_mean"], TARGETS["found"], " %", "high"),
        say("oriented handshape PCK@0.2 (median over clips)", summary["pck"], TARGETS["pck_median"], " %", "high"),
        say("oriented handshape PCK@0.2 (worst clip)", summary["pck_min"], TARGETS["pck_every_clip"], " %", "high"),
        say("wrist location (median over clips)", summary["location"], TARGETS["location_median"], " sw", "low"),
        say("letter top-1 penalty", summary["penalty"], TARGETS["letter_penalty"], " points", "low")])


def write_outputs(out: Path, rows: list[dict]) -> str:
    """clips.csv, languages.csv and summary.md in out; returns the summary's text."""
    import csv
    keys = ["language", "unit", "file", "frames", "fps", "width", "height", "framing", "hands", "found", "pck",
            "error", "shape_pck", "location", "movement", "mouth_error", "eyes_error", "zoom", "real_top1",
            "avatar_top1", "real_top3", "avatar_top3"]
    keys += [f"{hand}_{key}" for hand in SIDES for key in ("found", "pck", "error", "shape_pck", "location",
                                                           "location_p90", "movement")]
    with (out / "clips.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=keys, extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({key: (" ".join(row[key]) if isinstance(row.get(key), list) else row.get(key))
                             for key in keys})
    lines = table(rows)
    with (out / "languages.csv").open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["language"] + [key for key, _ in COLUMNS] + ["pck_min", "found_mean"])
        for language, summary in lines:
            writer.writerow([language] + [summary.get(key) for key, _ in COLUMNS] + [summary.get("pck_min"),
                                                                                   summary.get("found_mean")])
    size = f"{rows[0]['width']}x{rows[0]['height']}" if rows else "-"
    framings = sorted({row["framing"] for row in rows})
    text = "\n\n".join([
        f"Message fidelity, lexicon clips against the avatar's render ({size}, framing: {' and '.join(framings)}); "
        "medians over clips, letter top-1 over clips",
        markdown(lines), "Worst clips (oriented PCK):", worst(rows), "Targets (issue 34), 'all' row:",
        targets_text(lines[-1][1])])
    (out / "summary.md").write_text(text + "\n")
    return text


# ----------------------------------------------------------------------------------------------- main

def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise SigncastError(f"--size must be WIDTHxHEIGHT, e.g. 352x288, not {text!r}") from None
    if not (64 <= width <= 1920 and 64 <= height <= 1080):
        raise SigncastError(f"--size {text} is outside 64x64 .. 1920x1080")
    return width, height


def choose_clips(languages: list[str] | None, limit: int | None) -> list[tuple[str, str]]:
    """(language, unit) per clip: every clip of the languages (all if None), or `limit` per language spread evenly
    over its alphabet (a stratified subset); ordered round robin over the languages."""
    from media import lexicon
    codes = [lexicon.check_language(code) for code in languages] if languages else lexicon.languages()
    per_language = []
    for code in codes:
        units = lexicon.units(code)
        if limit is not None and limit < len(units):
            units = [units[i] for i in np.linspace(0, len(units) - 1, limit).round().astype(int)]
        per_language.append([(code, unit) for unit in units])
    # round robin over the languages, so that a run stopped early has measured a stratified subset
    return [clip for rank in range(max(map(len, per_language), default=0))
            for clips in per_language if rank < len(clips) for clip in [clips[rank]]]


def run(out: Path, clips: list[tuple[str, str]], size: tuple[int, int], jobs: int, measure: bool = True,
        framing: str = "source") -> list[dict]:
    """Measure the clips not yet in out/clips.jsonl (same size and framing), appending a row per clip as it finishes
    (measure False: none, report those there); returns the rows of the chosen clips that are there."""
    from tqdm import tqdm
    from media import lexicon
    from pipeline.studies.shared import StudyPool

    out.mkdir(parents=True, exist_ok=True)
    store = out / "clips.jsonl"
    done: dict[tuple[str, str], dict] = {}
    if store.exists():
        for number, line in enumerate(store.read_text().splitlines(), 1):
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                raise SigncastError(f"{store} line {number} is not a row of this benchmark (a run cut mid-line?): "
                                    "remove that line to resume") from None
            if (row["width"], row["height"]) == size and row.get("requested", row["framing"]) == framing:
                done[(row["language"], row["unit"])] = row
    by_file: dict[str, dict] = {row["file"]: row for row in done.values()}
    todo, copies = [], []
    for language, unit in clips:
        if (language, unit) in done or not measure:
            continue
        name = lexicon.lookup(language, unit).path.name
        if name in by_file or any(lexicon.lookup(*job[:2]).path.name == name for job in todo):
            copies.append((language, unit))            # fsl: the ase file, measured once
        else:
            todo.append((language, unit, size, framing))
    with store.open("a") as handle, tqdm(total=len(todo), desc="clips", unit="clip") as bar:
        def finished(_, row):
            row["requested"] = framing
            row.update(letter_result(row))
            del row["observed"]
            handle.write(json.dumps(row) + "\n")
            handle.flush()
            done[(row["language"], row["unit"])] = row
            by_file[row["file"]] = row
            bar.update(1)
        with StudyPool(jobs, _no_setup, (), preload=("numpy", "media.render", "media.landmarks.holistic")) as pool:
            pool.run(measure_clip, todo, finished)
        for language, unit in copies:
            # the same recording: the same render and, the other-signer pools leaving out the same files and the
            # alphabets being equal (fsl and ase: A-Z), the same letter results
            row = dict(by_file[lexicon.lookup(language, unit).path.name])
            row.update({"language": language, "unit": lexicon.lookup(language, unit).unit})
            handle.write(json.dumps(row) + "\n")
            done[(language, unit)] = row
    return [done[clip] for clip in clips if clip in done]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for clips.jsonl, the CSV tables, summary.md")
    parser.add_argument("--languages", nargs="+", help="lexicon language codes (default: all)")
    parser.add_argument("--limit", type=int, help="at most N clips per language, spread over its alphabet")
    parser.add_argument("--size", default="500x500",
                        help="render size WIDTHxHEIGHT (default 500x500: the lexicon's own frame)")
    parser.add_argument("--framing", default="source", choices=("source", "full-figure"),
                        help="the avatar framed like the clip's signer (default) or as the full figure")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    parser.add_argument("--report", action="store_true",
                        help="measure nothing: tables of the chosen clips already in OUT/clips.jsonl")
    args = parser.parse_args(argv)
    try:
        size = _size(args.size)
        if args.limit is not None and args.limit < 1:
            raise SigncastError(f"--limit must be at least 1, not {args.limit}")
        if args.jobs < 1:
            raise SigncastError(f"--jobs must be at least 1, not {args.jobs}")
        clips = choose_clips(args.languages, args.limit)
        started = time.perf_counter()
        rows = run(args.out, clips, size, args.jobs, measure=not args.report, framing=args.framing)
        if not rows:
            raise SigncastError(f"no measured clips in {args.out / 'clips.jsonl'} for these languages and --size")
        print(write_outputs(args.out, rows))
        print(f"\n{len(rows)} clips, {time.perf_counter() - started:.0f} s; tables in {args.out}")
    except SigncastError as error:
        print(f"message_fidelity: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"message_fidelity: interrupted; the clips measured so far are in {args.out / 'clips.jsonl'}: the same "
              "command resumes, --report tables them", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
