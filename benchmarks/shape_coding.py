"""How fast is the binary shape coder (comparisons/video/shape.py), per frame and object, both ways?

Live delivery (pipeline/live/objects.py, comparisons/transport/shape_units.py) codes every video object's shape every
frame, so all objects' shapes (and their texture) must fit in 40 ms at 25 fps on 2 cores. This renders the
first --frames frames of ASL "AB" by the NumPy backend at 176x144 and 352x288, takes the head, right hand,
signer and clothes masks (media.segmentation.object_masks), codes each sequence at GOP 12 and decodes it, and
prints milliseconds per frame (best of --repeats rounds after a warm-up round that also pays Numba's
compilation or cache load) beside the baseline below and the speed-up over it.

Baseline: the pure-Python coder (per-pixel loops in Python), measured on this project's 2-core build machine
before the loops moved into comparisons/video/shape_cae.py, same masks, same settings; ms per frame:

    size     object       encode  decode
    176x144  head           5.70    3.54
    176x144  right_hand     4.82    2.45
    176x144  signer        20.78    7.72
    176x144  clothes       15.93    4.98
    352x288  head          12.62    6.32
    352x288  right_hand     6.01    2.97
    352x288  signer        69.03   26.79
    352x288  clothes       43.10   14.53

    python benchmarks/shape_coding.py [--frames 20] [--repeats 3] [--cores 2]

--bits (issue 39): where the shape bits go instead of the speed. Per object (signer, head, each hand) of the
avatar's render of ASL "AB" at 320x240 (labels from the label buffer) and, with --clip carphone, of a real clip
(labels by the landmark segmentation): the share of each CAE block mode (transparent, opaque, intra, inter,
no update = "copy"), the bits by category (box, modes, shape motion vectors, intra and inter CAE pixels; the
information -log2 p of each decoded symbol, comparisons.video.shape.shape_bit_account), the blocks with a
vector and those whose vector differs from its prediction, the learning cost (pixel bits beyond a model that
knew each GOP's statistics) and the bits per shape per frame; then the bits per frame of the version 2 stream
(the coder before issue 39, lossless), and against them the lossless stream of today's encode_shape (the
shorter of version 3, where a predicted frame may reuse the previous box, and 4, which adds trained pixel
priors) and the lossy ones (the alpha threshold, comparisons.video.shape.encode_shape's
shape_error) at each --shape-error: bits per frame, their ratio to version 2's, and the shape error (wrong pixels
over the object's pixels) that the decoder's masks really have. Last, size conversion (stream version 5, CR 1/2
and 1/4 per coded BAB): at each --shape-error, bits per frame x version 2 and the measured shape error without
CR (the shorter of versions 3 and 4) and with it (version 5), and the share of coded BABs at CR 1, 1/2, 1/4.

    python benchmarks/shape_coding.py --bits [--frames 36] [--clip carphone] [--shape-error 0.5,1,2]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SIZES = ((176, 144), (352, 288))
OBJECTS = ("head", "right_hand", "signer", "clothes")
GOP = 12
BASELINE_MS: dict[tuple[str, str], tuple[float, float]] = {   # (size, object) -> (encode, decode) ms per frame
    ("176x144", "head"): (5.70, 3.54),
    ("176x144", "right_hand"): (4.82, 2.45),
    ("176x144", "signer"): (20.78, 7.72),
    ("176x144", "clothes"): (15.93, 4.98),
    ("352x288", "head"): (12.62, 6.32),
    ("352x288", "right_hand"): (6.01, 2.97),
    ("352x288", "signer"): (69.03, 26.79),
    ("352x288", "clothes"): (43.10, 14.53),
}


def pin(cores: int) -> None:
    """Hold this process to `cores` CPUs (the shape coder itself is single-threaded)."""
    available = sorted(os.sched_getaffinity(0))
    os.sched_setaffinity(0, set(available[:cores]))


def best_time(run, repeats: int) -> float:
    """Fewest seconds of run() over `repeats` rounds, after one warm-up round."""
    run()
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        run()
        times.append(time.perf_counter() - started)
    return min(times)


def render_masks(width: int, height: int, frames: int):
    """Object name -> (frames, height, width) bool masks of ASL "AB"."""
    from media.segmentation import object_masks

    masks = object_masks(avatar_labels(width, height, frames))
    return {name: masks[name] for name in OBJECTS}


BIT_OBJECTS = {"signer": (1, 2, 3, 4), "head": (2,), "left_hand": (3,), "right_hand": (4,)}


def avatar_labels(width: int, height: int, frames: int):
    """(frames, height, width) uint8 part labels of the avatar's render of ASL "AB" (its label buffer)."""
    import numpy as np

    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.render import AvatarRenderer, RenderSettings

    renderer = AvatarRenderer(load_avatar(), RenderSettings(width=width, height=height, backend="numpy"))
    labels = []
    for _, frame_labels in renderer.frames(fingerspell("ase", "AB")):
        labels.append(frame_labels)
        if len(labels) == frames:
            break
    return np.stack(labels)


def clip_labels(name: str, frames: int):
    """Part labels of a natural clip (pipeline.studies.shared: read, landmarks, landmark segmentation)."""
    from pipeline.studies.shared import read_natural_clip, segment_clip

    clip, _ = read_natural_clip(name, max_frames=frames, progress=False)
    return segment_clip(clip.frames, progress=False, method="landmarks", fps=clip.fps)


def print_bits(source: str, labels, shape_errors: tuple[float, ...]) -> None:
    import numpy as np

    from comparisons.video.shape import decode_shape, encode_shape, shape_bit_account

    print(f"\n{source}: {labels.shape[2]}x{labels.shape[1]}, {labels.shape[0]} frames, GOP {GOP}")
    print(f"{'object':11} {'transp':>6} {'opaque':>6} {'intra':>6} {'inter':>6} {'copy':>6}  {'box':>5} {'mode':>5}"
          f" {'mv':>5} {'intra':>5} {'inter':>5} {'learn':>5} {'mv blk':>7} {'bits/frame':>10}")
    print(f"{'':11} {'(% of coded blocks)':>34}  {'(% of the payload bits)':>29} {'moved':>13}")
    for name, parts in BIT_OBJECTS.items():
        masks = np.isin(labels, parts)
        stream, _ = encode_shape(masks, gop=GOP)
        account = shape_bit_account(stream)
        modes = account["modes"]
        blocks = max(1, sum(modes.values()))
        bits = account["bits"]
        payload = max(1e-9, sum(bits.values()))
        shares = " ".join(f"{100 * modes[m] / blocks:6.1f}" for m in ("transparent", "opaque", "intra_cae",
                                                                      "inter_cae", "copy"))
        costs = " ".join(f"{100 * bits[c] / payload:5.1f}" for c in ("header", "mode", "mv", "intra_cae",
                                                                     "inter_cae"))
        print(f"{name:11} {shares}  {costs} {100 * account['learning_bits'] / payload:5.1f}"
              f" {account['mv_nonzero']:3d}/{account['mv_blocks']:<4d}"
              f" {account['total_bits'] / account['frames']:10.1f}", flush=True)
    if not shape_errors:
        return
    print("bits/frame, x the version 2 stream (the coder before issue 39), measured shape error %: lossless "
          "(the shorter of version 3, same-box flag, and 4, also trained priors), then lossy (alpha threshold)")
    print(f"{'object':11} {'version 2':>9} {'lossless':>24} "
          + " ".join(f"{'<= ' + format(e, 'g') + ' %':>24}" for e in shape_errors))
    for name, parts in BIT_OBJECTS.items():
        masks = np.isin(labels, parts)
        lossless = len(encode_shape(masks, gop=GOP, version=2)[0])
        cells = []
        for error in (0.0, *shape_errors):
            stream, stats = encode_shape(masks, gop=GOP, shape_error=error)
            wrong = int(np.count_nonzero(decode_shape(stream) != masks))
            if wrong != stats.error_pixels:
                raise SystemExit(f"{name}: the decoder's masks are not the encoder's")
            measured = 100.0 * wrong / max(1, int(masks.sum()))
            cells.append(f"{8 * len(stream) / len(masks):9.1f} {len(stream) / lossless:5.2f}x {measured:6.2f}%")
        print(f"{name:11} {8 * lossless / len(masks):9.1f} " + " ".join(f"{c:>24}" for c in cells), flush=True)
    print_size_conversion(labels, shape_errors)


def print_size_conversion(labels, shape_errors: tuple[float, ...]) -> None:
    """Per object and --shape-error: without size conversion (the shorter of versions 3 and 4) and with it
    (version 5): bits per frame, x version 2, measured shape error, and the CR shares of the coded BABs."""
    import numpy as np

    from comparisons.video.shape import decode_shape, encode_shape

    print("size conversion: bits/frame, x version 2, measured shape error % without CR (versions 3/4) and with "
          "CR (version 5); CR shares of coded BABs % (1, 1/2, 1/4)")
    print(f"{'object':11} {'error':>5} {'version 2':>9} {'without CR':>24} {'with CR':>24} {'CR 1':>6} {'1/2':>6}"
          f" {'1/4':>6}")
    for name, parts in BIT_OBJECTS.items():
        masks = np.isin(labels, parts)
        if not masks.any():
            continue
        base = len(encode_shape(masks, gop=GOP, version=2)[0])
        pixels = max(1, int(masks.sum()))
        for error in shape_errors:
            cells = []
            for versions in ((3, 4), (5,)):
                stream, stats = min((encode_shape(masks, gop=GOP, shape_error=error, version=v) for v in versions),
                                    key=lambda coded: len(coded[0]))
                decoded = decode_shape(stream)
                if not np.array_equal(decoded, stats.reconstruction):
                    raise SystemExit(f"{name}: the decoder's masks are not the encoder's")
                measured = 100.0 * int(np.count_nonzero(decoded != masks)) / pixels
                cells.append(f"{8 * len(stream) / len(masks):9.1f} {len(stream) / base:5.2f}x {measured:6.2f}%")
            shares = stats.cr_counts
            coded = max(1, sum(shares.values()))
            print(f"{name:11} {error:5g} {8 * base / len(masks):9.1f} {cells[0]:>24} {cells[1]:>24} "
                  + " ".join(f"{100 * shares[k] / coded:6.1f}" for k in ("1", "1/2", "1/4")), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cores", type=int, default=2)
    parser.add_argument("--bits", action="store_true", help="where the shape bits go (modes, vectors, learning)")
    parser.add_argument("--clip", default=None, help="with --bits, also a natural clip (e.g. carphone)")
    parser.add_argument("--shape-error", default="0.5,1,2",
                        help="with --bits, the lossy settings (percent of the object's pixels, comma-separated)")
    args = parser.parse_args()
    pin(args.cores)
    if args.bits:
        frames = args.frames if args.frames != 20 else 36
        errors = tuple(float(e) for e in args.shape_error.split(",") if e.strip())
        print_bits('avatar ASL "AB" (label buffer)', avatar_labels(320, 240, frames), errors)
        if args.clip:
            print_bits(f"{args.clip} (landmark segmentation)", clip_labels(args.clip, frames), errors)
        return

    import numpy as np

    from comparisons.video.shape import decode_shape, encode_shape

    print(f"{'size':8} {'object':11} {'enc ms':>7} {'dec ms':>7} {'bytes':>6}   {'base enc':>8} {'base dec':>8}"
          f" {'enc x':>6} {'dec x':>6}")
    for width, height in SIZES:
        size = f"{width}x{height}"
        for name, masks in render_masks(width, height, args.frames).items():
            frames = len(masks)
            stream, _ = encode_shape(masks, gop=GOP)
            if not np.array_equal(decode_shape(stream), masks):
                raise SystemExit(f"{size} {name}: the shape stream does not decode to its masks")
            encode_ms = 1000 * best_time(lambda masks=masks: encode_shape(masks, gop=GOP), args.repeats) / frames
            decode_ms = 1000 * best_time(lambda stream=stream: decode_shape(stream), args.repeats) / frames
            line = f"{size:8} {name:11} {encode_ms:7.2f} {decode_ms:7.2f} {len(stream):6d}"
            if (size, name) in BASELINE_MS:
                base_encode, base_decode = BASELINE_MS[(size, name)]
                line += (f"   {base_encode:8.2f} {base_decode:8.2f} {base_encode / encode_ms:6.1f}"
                         f" {base_decode / decode_ms:6.1f}")
            print(line, flush=True)


if __name__ == "__main__":
    main()
