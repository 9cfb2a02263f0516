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


def _changed_mask(block: np.ndarray, held: np.ndarray, steps: np.ndarray) -> np.ndarray:
    return np.any(pc.quantize(block - held, steps) != 0, axis=0)


def _write_predictive_period(writer: BitWriter, block: np.ndarray, held: np.ndarray, q: int, fps: float,
                             tight: bool) -> tuple[np.ndarray, bool]:
    """Codes one intra period; returns the decoder's values after it and whether it fit."""
    steps_all = bap_table.steps() * q
    mask = _changed_mask(block, held, steps_all)
    order = coded_order(mask)
    steps = steps_all[order]
    intra, p_levels, recon = pc.predictive_levels(block[:, order], held[order], steps, q)
    if tight:
        fields = np.stack([*pc.range_fields(intra[None], q), *pc.range_fields(p_levels, q)])
    else:
        fields = np.full((4, len(order)), pc.DEFAULT_RANGE_FIELD, dtype=np.int64)
    i_low, i_high = pc.alphabet(fields[0], fields[1], q)
    p_low, p_high = pc.alphabet(fields[2], fields[3], q)
    fits = bool(np.all((intra >= i_low) & (intra <= i_high)) and np.all((p_levels >= p_low) & (p_levels <= p_high)))
    if not fits:
        return held, False
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
    return after, True


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


def _prefer_tight_ranges(block: np.ndarray, held: np.ndarray, q: int) -> bool:
    """Send per-BAP ranges when their 28 bits per masked BAP cost less than coding every level in
    the default alphabets (estimated as log2 of the alphabet sizes), or when the defaults are too small."""
    steps_all = bap_table.steps() * q
    order = coded_order(_changed_mask(block, held, steps_all))
    intra, p_levels, _ = pc.predictive_levels(block[:, order], held[order], steps_all[order], q)
    fields = np.stack([*pc.range_fields(intra[None], q), *pc.range_fields(p_levels, q)])
    if np.any(fields > pc.DEFAULT_RANGE_FIELD):
        return True
    def bits(f: np.ndarray) -> float:
        i_low, i_high = pc.alphabet(f[0], f[1], q)
        p_low, p_high = pc.alphabet(f[2], f[3], q)
        return float(np.log2(i_high - i_low + 1).sum() + len(p_levels) * np.log2(p_high - p_low + 1).sum())
    default = np.full_like(fields, pc.DEFAULT_RANGE_FIELD)
    return bits(fields) + 4 * pc.RANGE_BITS * len(order) < bits(default)


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

    coding: "pred" (frame-predictive + arithmetic coding) or "dct" (16-frame DCT + VLC)."""
    q = pc.check_q(q)
    values = np.asarray(values, dtype=np.int64)
    if values.ndim != 2 or values.shape[1] != bap_table.N_BAPS or len(values) == 0:
        raise SigncastError(f"BAP values must be (T >= 1, {bap_table.N_BAPS}), got {values.shape}")
    if coding not in ("pred", "dct"):
        raise SigncastError(f"unknown FBA coding {coding!r}: choose 'pred' or 'dct'")
    period = intra_period if coding == "pred" else intra_segments * pc.SEGMENT
    if period < 1:
        raise SigncastError("the intra period must be at least one frame (segment)")
    writer = BitWriter()
    writer.start_code(OBJECT_START_CODE)
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    for start in range(0, len(values), period):
        block = values[start:start + period]
        if coding == "dct":
            held = _write_dct_period(writer, block, held, q, fps, start + period >= len(values))
            continue
        tight = _prefer_tight_ranges(block, held, q)
        held, fits = _write_predictive_period(writer, block, held, q, fps, tight)
        if not fits:
            raise SigncastError("internal error: an intra period did not fit its ranges")
    writer.start_code(END_CODE)
    data = writer.getvalue()
    return data + zlib.crc32(data).to_bytes(4, "big")


def decode_fba(data: bytes) -> tuple[np.ndarray, float]:
    """(values (T, 296) int64, fps) of an FBA stream; SigncastError if it is corrupt or truncated."""
    data = bytes(data)
    if len(data) < 12 or zlib.crc32(data[:-4]).to_bytes(4, "big") != data[-4:]:
        raise SigncastError("corrupt or truncated FBA stream: checksum mismatch")
    data = data[:-4]
    reader = BitReader(data)
    if reader.read_start_code() != OBJECT_START_CODE:
        raise SigncastError("not an FBA stream: it does not start with fba_object_start_code")
    held = np.zeros(bap_table.N_BAPS, dtype=np.int64)
    frames: list[np.ndarray] = []
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
                frames.append(held.copy())
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
                frames.append(held.copy())
            else:
                _read_dct_segment(reader, state, False, held, frames)
    if reader.pos != 8 * len(data):
        raise SigncastError("corrupt FBA stream: data after the end code")
    if not frames or fps is None:
        raise SigncastError("corrupt FBA stream: no frames")
    return np.stack(frames), fps


def _read_dct_segment(reader: BitReader, state: list, intra: bool, held: np.ndarray, frames: list) -> None:
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
        frames.append(held.copy())
