"""MPEG-4 FBA body stream (BAPs only): predictive and DCT coders, with their decoders.

Syntax (mpeg4-facts.md §2.1-2.4, after the visage FBA encoder that follows ISO/IEC 14496-2
Amd.1; seed 000 §2.1; seed 004 "BAP Grouping"):

    fba_object_start_code 0x000001BA
    repeat: [fba_object_plane_start_code 0x000001BB before every intra plane]
        is_intra u1, fba_object_mask u2 (= 2, BAPs)
        intra: is_frame_rate u1 (1), frame_rate u8, seconds u4, frequency_offset u1, is_time_code u1 (0)
        skip_frames u1 (0)
        intra: bap_quant u5 (= Q), per group 1..24: marker u1, bap_mask_type u2 (0 none, 3 all,
               1 + one bit per BAP in group order), gender u1, coding_type u1 (0 predictive, 1 DCT)
        predictive intra: is_i_new_max, is_i_new_min, is_p_new_max, is_p_new_min u1 each;
               range fields (param_coding); then the arithmetic-coded levels of every masked BAP
        predictive P plane: the arithmetic-coded residual levels
        DCT plane (a 16-frame segment): is_last u1 [+ frames-1 u4], per masked BAP a DCT block
    visual_object_sequence_end_code 0x000001B1
    CRC-32 (zlib) of all the bytes before it, 4 bytes (signcast's container check, not in the standard:
    the FBA syntax itself has no check, so bit errors in Huffman-coded DCT data would decode silently)

Masks (which BAPs are sent) are set at each intra plane and hold until the next; BAPs outside
the mask keep their last value (0 at the start). The encoder masks in exactly the BAPs whose
quantised value changes during the intra period, so unchanged groups cost 3 bits.

Chosen here (no source): intra period 32 frames (predictive) and 4 segments (DCT); the 7-bit
range fields (param_coding); the encoder sends tight ranges for an intra period unless the default
(+-31 fields) alphabets are estimated to cost less (log2 of the alphabet sizes per coded level).
Nothing is clipped. A predictive period ends early where a residual is too large for the range
fields (a step-64 angle crossing +-pi, a root jump over ~15 m): the next intra plane starts at that
frame and sends absolute values, so the stream stays standard and every value decodes within half
a step. No ASL letter crosses +-pi (their streams are byte-identical to before). Wrapping angle
residuals modulo 2 pi would be cheaper only for motion that keeps crossing it (a root twist
jittering about pi: 2.3x the bytes with intra escapes, ~1.03x with DCT), but 2 pi is not a whole
number of 1e-5 rad units and a standard decoder does not wrap. A value whose intra level is too
large (|root translation| > ~15 m) is refused with SigncastError.

Streams hold at most MAX_FRAMES frames; the encoder refuses longer input and the decoder stops
with SigncastError at frame MAX_FRAMES + 1 (a 15.6 kB DCT stream can hold 400,000 still
frames, 0.95 GB once decoded).
"""
from __future__ import annotations

import zlib

import numpy as np

from comparisons import bap_table
from comparisons import param_coding as pc
from comparisons.bitstream import BitReader, BitWriter
from media.errors import SigncastError

OBJECT_START_CODE = 0xBA
PLANE_START_CODE = 0xBB
END_CODE = 0xB1
PARAMSET_BAP = 2
PREDICTIVE, DCT = 0, 1
DEFAULT_INTRA_PERIOD = 32
DEFAULT_INTRA_SEGMENTS = 4
MAX_FRAMES = 216_000        # 1 h at 60 fps, 2 h at 30 fps; decoded (T, 296) int64 <= 511 MB
DECODE_BLOCK = 1024         # the decoder stores frames in blocks of this many
MAX_ABS_VALUE = 2 ** 31 - 1  # input guard, far beyond any BAP's range


def coded_order(mask: np.ndarray) -> np.ndarray:
    """0-based indices of the masked BAPs, in coding order (group by group)."""
    return np.array([i - 1 for group in bap_table.GROUP_MEMBERS for i in group if mask[i - 1]], dtype=np.int64)


def write_plane_header(writer: BitWriter, intra: bool, fps: float) -> None:
    writer.write_bit(int(intra))
    writer.write(PARAMSET_BAP, 2)
    if intra:
        rate, seconds, offset = pc.frame_rate_fields(fps)
        writer.write_bit(1)
        writer.write(rate, 8)
        writer.write(seconds, 4)
        writer.write_bit(offset)
        writer.write_bit(0)                  # is_time_code
    writer.write_bit(0)                      # skip_frames


def read_plane_header(reader: BitReader) -> tuple[bool, float | None]:
    intra = bool(reader.read_bit())
    if reader.read(2) != PARAMSET_BAP:
        raise SigncastError("corrupt FBA stream: object plane carries no BAPs (only BAP streams are supported)")
    fps = None
    if intra:
        if reader.read_bit():
            rate, seconds, offset = reader.read(8), reader.read(4), reader.read_bit()
            fps = pc.fps_from_fields(rate, seconds, offset)
        if reader.read_bit():
            raise SigncastError("corrupt FBA stream: time codes are not supported")
    if reader.read_bit():
        raise SigncastError("corrupt FBA stream: frame skipping is not supported")
    return intra, fps


def write_group_masks(writer: BitWriter, mask: np.ndarray) -> None:
    for group in bap_table.GROUP_MEMBERS:
        writer.write_bit(1)
        flags = [bool(mask[i - 1]) for i in group]
        if not any(flags):
            writer.write(0, 2)
        elif all(flags):
            writer.write(3, 2)
        else:
            writer.write(1, 2)
            for flag in flags:
                writer.write_bit(int(flag))


def read_group_masks(reader: BitReader) -> np.ndarray:
    mask = np.zeros(bap_table.N_BAPS, dtype=bool)
    for group in bap_table.GROUP_MEMBERS:
        if reader.read_bit() != 1:
            raise SigncastError("corrupt FBA stream: missing marker bit in the group masks")
        kind = reader.read(2)
        if kind == 3:
            mask[np.array(group) - 1] = True
        elif kind == 1:
            for i in group:
                mask[i - 1] = bool(reader.read_bit())
        elif kind == 2:
            raise SigncastError("corrupt FBA stream: BAP mask type 2 is not defined")
    return mask


SETTLING_BAPS = 8          # BAPs that jump once and hold before a one-frame intra plane pays for itself
SETTLING_MIN_FRAMES = 8


def _changed_mask(block: np.ndarray, held: np.ndarray, steps: np.ndarray) -> np.ndarray:
    return np.any(pc.quantize(block - held, steps) != 0, axis=0)


def _predictive_period(block: np.ndarray, held: np.ndarray, q: int):
    """The predictive coder's decisions for the longest prefix of `block` (T, 296) that one intra
    period can carry: (frames, mask (296,) bool, coded order, intra levels (P,), P levels
    (frames - 1, P), decoder values (frames, P)). SigncastError if an intra value cannot be sent."""
    steps_all = bap_table.steps() * q
    mask = _changed_mask(block, held, steps_all)
    order = coded_order(mask)
    intra, p_levels, recon = pc.predictive_levels(block[:, order], held[order], steps_all[order], q)
    too_large = np.flatnonzero(np.abs(intra) > pc.level_limit(q))
    if len(too_large):
        bap = bap_table.bap(int(order[too_large[0]]) + 1)
        unit = "mm" if bap.is_translation else "x 1e-5 rad"
        raise SigncastError(f"BAP {bap.id} ({bap.name}) value {int(block[0, bap.id - 1])} {unit} cannot be sent at "
                            f"Q={q}: an FBA intra plane carries at most +-{pc.level_limit(q) * bap.step * q}")
    frames = pc.fitting_frames(p_levels, q)
    if frames < len(block):              # a residual too large for the range fields: new intra plane there
        return _predictive_period(block[:frames], held, q)
    return frames, mask, order, intra, p_levels, recon


def _settles_at_once(block: np.ndarray, held: np.ndarray, q: int) -> bool:
    """Whether SETTLING_BAPS or more BAPs of block (T, 296) change from the held values (296,) at its first frame
    and then hold (a rest pose set at the start of a stream): in one intra period they would be masked in and
    cost a zero residual in every P frame, so a one-frame intra plane that sets them is cheaper."""
    if len(block) < SETTLING_MIN_FRAMES:
        return False
    steps = bap_table.steps() * q
    levels = pc.quantize(block - held, steps)
    settled = (levels[0] != 0) & np.all(levels == levels[0], axis=0)
    return int(settled.sum()) >= SETTLING_BAPS


def _write_predictive_period(writer: BitWriter, period: tuple, held: np.ndarray, q: int, fps: float) -> np.ndarray:
    """Codes one intra period (from _predictive_period); returns the decoder's values after it."""
    _, mask, order, intra, p_levels, recon = period
    fields = np.stack([*pc.range_fields(intra[None], q), *pc.range_fields(p_levels, q)])
    tight = _prefer_tight_ranges(fields, len(p_levels), q)
    if not tight:
        fields = np.full((4, len(order)), pc.DEFAULT_RANGE_FIELD, dtype=np.int64)
    i_low, i_high = pc.alphabet(fields[0], fields[1], q)
    p_low, p_high = pc.alphabet(fields[2], fields[3], q)
    writer.start_code(PLANE_START_CODE)
    write_plane_header(writer, True, fps)
    writer.write(q, 5)
    write_group_masks(writer, mask)
    writer.write_bit(0)                      # gender
    writer.write_bit(PREDICTIVE)
    for _ in range(4):
        writer.write_bit(int(tight))
    if tight:
        pc.write_range_fields(writer, fields)
    pc.write_levels(writer, intra, pc.make_models(i_low, i_high), i_low)
    p_models = pc.make_models(p_low, p_high)
    for levels in p_levels:
        write_plane_header(writer, False, fps)
        pc.write_levels(writer, levels, p_models, p_low)
    after = held.copy()
    after[order] = recon[-1]
    return after


def dct_period(block: np.ndarray, held: np.ndarray, q: int):
    """The DCT coder's decisions for one intra period: (mask (296,) bool, coded order, DC step,
    AC step, segments [(n_frames, DC levels (P,), AC levels (15, P))])."""
    steps_all = bap_table.steps()
    mask = _changed_mask(block, held, steps_all * q)
    order = coded_order(mask)
    dc_step, ac_step = pc.dct_steps(steps_all[order], q)
    segments = []
    for start in range(0, len(block), pc.SEGMENT):
        segment = block[start:start + pc.SEGMENT, order]
        segments.append((len(segment), *pc.dct_levels(segment, dc_step, ac_step)))
    return mask, order, dc_step, ac_step, segments


def dct_training_symbols(values: np.ndarray, q: int, intra_segments: int = DEFAULT_INTRA_SEGMENTS) -> list:
    """(DC values as coded, AC levels, intra) of every segment the DCT coder would code (VLC design)."""
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    out = []
    period = intra_segments * pc.SEGMENT
    for start in range(0, len(values), period):
        mask, order, dc_step, ac_step, segments = dct_period(values[start:start + period], held, q)
        previous = None
        for k, (n, dc, ac) in enumerate(segments):
            out.append((dc if k == 0 else dc - previous, ac, k == 0))
            previous = dc
            held[order] = pc.dct_reconstruct(dc, ac, dc_step, ac_step)[n - 1]
    return out


def _prefer_tight_ranges(fields: np.ndarray, n_p_frames: int, q: int) -> bool:
    """Send the per-BAP ranges `fields` (4, P) when their 28 bits per masked BAP cost less than
    coding every level in the default alphabets (estimated as log2 of the alphabet sizes), or when
    the defaults are too small."""
    if np.any(fields > pc.DEFAULT_RANGE_FIELD):
        return True
    def bits(f: np.ndarray) -> float:
        i_low, i_high = pc.alphabet(f[0], f[1], q)
        p_low, p_high = pc.alphabet(f[2], f[3], q)
        return float(np.log2(i_high - i_low + 1).sum() + n_p_frames * np.log2(p_high - p_low + 1).sum())
    default = np.full_like(fields, pc.DEFAULT_RANGE_FIELD)
    return bits(fields) + 4 * pc.RANGE_BITS * fields.shape[1] < bits(default)


def _write_dct_period(writer: BitWriter, block: np.ndarray, held: np.ndarray, q: int, fps: float,
                      is_last_period: bool) -> np.ndarray:
    tables = pc.vlc_tables()
    mask, order, dc_step, ac_step, segments = dct_period(block, held, q)
    previous_dc = None
    after = held.copy()
    for k, (n, dc, ac) in enumerate(segments):
        intra = k == 0
        if intra:
            writer.start_code(PLANE_START_CODE)
        write_plane_header(writer, intra, fps)
        if intra:
            writer.write(q, 5)
            write_group_masks(writer, mask)
            writer.write_bit(0)
            writer.write_bit(DCT)
        last = is_last_period and k == len(segments) - 1
        writer.write_bit(int(last))
        if last:
            writer.write(n - 1, 4)
        dc_values = dc if intra else dc - previous_dc
        for p in range(len(order)):
            pc.write_dct_block(writer, tables, int(dc_values[p]), intra, ac[:, p])
        previous_dc = dc
        after[order] = pc.dct_reconstruct(dc, ac, dc_step, ac_step)[n - 1]
    return after


def encode_fba(values: np.ndarray, fps: float, q: int, coding: str = "pred", *,
               intra_period: int = DEFAULT_INTRA_PERIOD, intra_segments: int = DEFAULT_INTRA_SEGMENTS) -> bytes:
    """FBA stream of BAP values (T, 296) int64 at `fps`, global quantisation Q in 1..31.

    coding: "pred" (frame-predictive + arithmetic coding) or "dct" (16-frame DCT + VLC).
    SigncastError for more than MAX_FRAMES frames, or a value the stream cannot carry."""
    q = pc.check_q(q)
    values = np.asarray(values, dtype=np.int64)
    if values.ndim != 2 or values.shape[1] != bap_table.N_BAPS or len(values) == 0:
        raise SigncastError(f"BAP values must be (T >= 1, {bap_table.N_BAPS}), got {values.shape}")
    if len(values) > MAX_FRAMES:
        raise SigncastError(f"an FBA stream holds at most {MAX_FRAMES} frames, got {len(values)}: split the motion")
    if values.min() < -MAX_ABS_VALUE or values.max() > MAX_ABS_VALUE:    # keeps the int64 level arithmetic exact
        raise SigncastError(f"BAP values beyond +-{MAX_ABS_VALUE} cannot be coded (rotations are within +-314159)")
    if coding not in ("pred", "dct"):
        raise SigncastError(f"unknown FBA coding {coding!r}: choose 'pred' or 'dct'")
    period = intra_period if coding == "pred" else intra_segments * pc.SEGMENT
    if period < 1:
        raise SigncastError("the intra period must be at least one frame (segment)")
    writer = BitWriter()
    writer.start_code(OBJECT_START_CODE)
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    start = 0
    while start < len(values):
        block = values[start:start + period]
        if coding == "dct":
            held = _write_dct_period(writer, block, held, q, fps, start + period >= len(values))
        else:
            if _settles_at_once(block, held, q):      # values that jump once and hold: an intra plane of one frame
                block = block[:1]
            decisions = _predictive_period(block, held, q)
            block = block[:decisions[0]]
            held = _write_predictive_period(writer, decisions, held, q, fps)
        start += len(block)
    writer.start_code(END_CODE)
    data = writer.getvalue()
    return data + zlib.crc32(data).to_bytes(4, "big")


class _DecodedFrames:
    """Decoded BAP frames, stored in blocks of DECODE_BLOCK frames so that memory grows with the
    frames decoded; refuses frame max_frames + 1 before storing it."""

    def __init__(self, max_frames: int) -> None:
        self.max_frames = max_frames
        self.blocks: list[np.ndarray | None] = []
        self.count = 0

    def append(self, values: np.ndarray) -> None:
        """values: (296,) int64, one frame."""
        if self.count >= self.max_frames:
            raise SigncastError(f"FBA stream holds more than {self.max_frames} frames, the decoder's limit")
        row = self.count % DECODE_BLOCK
        if row == 0:
            self.blocks.append(np.empty((DECODE_BLOCK, bap_table.N_BAPS), dtype=np.int64))
        self.blocks[-1][row] = values
        self.count += 1

    def array(self) -> np.ndarray:
        """(count, 296) int64; releases each block once copied, so the peak is the output plus one block."""
        out = np.empty((self.count, bap_table.N_BAPS), dtype=np.int64)
        for k in range(len(self.blocks)):
            rows = out[k * DECODE_BLOCK:(k + 1) * DECODE_BLOCK]
            rows[:] = self.blocks[k][:len(rows)]
            self.blocks[k] = None
        return out


def decode_fba(data: bytes, *, max_frames: int = MAX_FRAMES) -> tuple[np.ndarray, float]:
    """(values (T, 296) int64, fps) of an FBA stream; SigncastError if it is corrupt or truncated,
    or holds more than `max_frames` frames (checked while decoding: memory stays within the limit)."""
    data = bytes(data)
    if len(data) < 12 or zlib.crc32(data[:-4]).to_bytes(4, "big") != data[-4:]:
        raise SigncastError("corrupt or truncated FBA stream: checksum mismatch")
    data = data[:-4]
    reader = BitReader(data)
    if reader.read_start_code() != OBJECT_START_CODE:
        raise SigncastError("not an FBA stream: it does not start with fba_object_start_code")
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    frames = _DecodedFrames(max_frames)
    fps = None
    state = None
    while True:
        if reader.at_start_code():
            code = reader.read_start_code()
            if code == END_CODE:
                break
            if code != PLANE_START_CODE:
                raise SigncastError(f"corrupt FBA stream: unexpected start code 0x{code:02X}")
        intra, plane_fps = read_plane_header(reader)
        if intra:
            fps = plane_fps or fps
            q = reader.read(5)
            if q == 0:
                raise SigncastError("corrupt FBA stream: bap_quant 0")
            mask = read_group_masks(reader)
            reader.read_bit()                # gender
            coding = reader.read_bit()
            order = coded_order(mask)
            if coding == PREDICTIVE:
                flags = [reader.read_bit() for _ in range(4)]
                if len(set(flags)) != 1:
                    raise SigncastError("corrupt FBA stream: mixed range flags are not supported")
                fields = (pc.read_range_fields(reader, len(order)) if flags[0]
                          else np.full((4, len(order)), pc.DEFAULT_RANGE_FIELD, dtype=np.int64))
                i_low, i_high = pc.alphabet(fields[0], fields[1], q)
                p_low, p_high = pc.alphabet(fields[2], fields[3], q)
                if np.any(i_high - i_low >= 32768) or np.any(p_high - p_low >= 32768):
                    raise SigncastError("corrupt FBA stream: impossible value ranges")
                steps = bap_table.steps()[order] * q
                levels = pc.read_levels(reader, pc.make_models(i_low, i_high), i_low)
                held[order] = levels * steps
                state = ("pred", order, steps, pc.make_models(p_low, p_high), p_low)
                frames.append(held)
            else:
                dc_step, ac_step = pc.dct_steps(bap_table.steps()[order], q)
                state = ["dct", order, dc_step, ac_step, None]
                _read_dct_segment(reader, state, True, held, frames)
        else:
            if state is None:
                raise SigncastError("corrupt FBA stream: a predicted plane comes before any intra plane")
            if state[0] == "pred":
                _, order, steps, p_models, p_low = state
                held[order] += pc.read_levels(reader, p_models, p_low) * steps
                frames.append(held)
            else:
                _read_dct_segment(reader, state, False, held, frames)
    if reader.pos != 8 * len(data):
        raise SigncastError("corrupt FBA stream: data after the end code")
    if not frames.count or fps is None:
        raise SigncastError("corrupt FBA stream: no frames")
    return frames.array(), fps


def _read_dct_segment(reader: BitReader, state: list, intra: bool, held: np.ndarray, frames: _DecodedFrames) -> None:
    _, order, dc_step, ac_step, previous_dc = state
    tables = pc.vlc_tables()
    n = pc.SEGMENT
    if reader.read_bit():
        n = reader.read(4) + 1
    dc = np.zeros(len(order), dtype=np.int64)
    ac = np.zeros((n - 1, len(order)), dtype=np.int64)
    for p in range(len(order)):
        dc[p], ac[:, p] = pc.read_dct_block(reader, tables, intra, n)
    if not intra:
        dc += previous_dc
    state[4] = dc
    segment = pc.dct_reconstruct(dc, ac, dc_step, ac_step)
    for t in range(n):
        held[order] = segment[t]
        frames.append(held)
