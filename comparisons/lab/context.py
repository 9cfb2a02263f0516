"""Numba kernels of the context-modelled wavelet coder (comparisons/lab/waveform.py ContextWaveletCoder,
which documents the stream): a binary range coder with adaptive probabilities, and the binarisation and
context selection of the wavelet coefficients, written once for both ends (`_code_bit` encodes the given
bit or decodes one).

Range coder (chosen here, after LZMA's rc: 32-bit range, carry propagated through a cached byte and a count
of pending 0xFF bytes): probabilities are 16-bit (P(bit = 0) x 65536, kept in [PROB_MIN, 65536 - PROB_MIN]);
the range is split at (range >> 16) x P. The encoder's first output byte (always 0) is not stored and the
flush writes 4 bytes; the decoder reads 4 bytes to start and one per renormalisation, so it consumes exactly
the payload: a payload that does not end where the decoder stops, or that the decoder reads more than
MAX_OVERRUN bytes past, is rejected (status -1).

Adaptation (chosen here): each context keeps (P, n); after a bit, P moves towards it by 1 / (n + 2) while
n + 2 < 2^RATE_SHIFT (the running average of the first bits, fast on short clips), then by 2^-RATE_SHIFT.

Coefficients: (D, n_blocks, 16) int64 in the dyadic layout [approximation, level 1 (1), level 2 (2),
level 3 (4), level 4 (8)], the approximation already differenced along the blocks. Per DOF, per block,
position 0..15: class k = bit length of |v| (0..MAX_CLASS) in unary ("k > j?" for j = 0, 1, ...; no stop
bit at MAX_CLASS), then for k > 0 the sign, the top bit below the leading one (context: k), for k >= 3 the
second bit below it (context: k; inside a class a Laplacian's values are not flat), the rest at P = 1/2. Class
contexts: the band (approximation of the first block, later approximations, levels 1..4), the predicted class
pc = bit length of 2 |previous coefficient of the band in time| + |parent| (the approximation: of the previous
block's difference), j relative to pc (clamped to -3..3), pc's bucket (0, 1-2, 3-5, 6+: how far the relative
j is to be trusted differs between small and large coefficients) and j = 0.

The range coder is written once (`_encode_bit`, `_decode_bit`, `_adapt`, `_code_bit`); both ways in below use it.
Two ways in: `encode` / `decode` code one b"C" section of the SCM1 container with every model at P = 1/2; the
compact stream (ContextWaveletCoder.encode_compact) codes the active-DOF mask (one bin per DOF of the signing
layout, context: the DOF and the previous DOF's bit) and then the coefficients in one payload (there, the inter-DOF
prediction residuals of comparisons/lab/waveform.predict_dofs: these kernels code any integers), its models starting
from trained states (encode_payload; decode_mask then decode_coefficients on one decoder state, since the decoder
sizes the coefficients from the mask). `code_mask` / `code_coefficients` with a tally (n_contexts, 2) count the
bits each context codes: tools/train_context_priors.py trains the states from that.
"""
import numpy as np
from numba import njit

PROB_BITS = 16
PROB_ONE = 1 << PROB_BITS
PROB_MIN = 32
RATE_SHIFT = 6
TOP = 1 << 24
MASK32 = (1 << 32) - 1
MAX_CLASS = 40
MAX_OVERRUN = 4
BLOCK = 16
N_BANDS = 6                   # first approximation, approximation, levels 1..4
REL = 7                       # j - pc clamped to -3..3
PCB = 4                       # buckets of pc: 0, 1-2, 3-5, 6+
CLASS_CONTEXTS = N_BANDS * REL * PCB * 2
SIGN_BASE = CLASS_CONTEXTS
SIGN_CONTEXTS = N_BANDS * 9          # band x sign of the previous coefficient x sign of the parent (-, 0, +)
MANTISSA_BASE = SIGN_BASE + SIGN_CONTEXTS
MANTISSA2_BASE = MANTISSA_BASE + MAX_CLASS + 1
N_CONTEXTS = MANTISSA2_BASE + MAX_CLASS + 1
# coder state (int64): encoder low, range, cache, pending, bytes out, first; decoder code, range, pos, overrun
LOW, RANGE, CACHE, PENDING, OUT, FIRST = range(6)
CODE, DRANGE, POS, OVER = range(4)


@njit(cache=True)
def payload_capacity(n_values: int) -> int:
    """A first guess of the payload's size for n_values coefficients: 12 bytes each (more than any smooth
    motion needs); `encode` says when it was not enough."""
    return 12 * n_values + 64


@njit(cache=True)
def _put(out: np.ndarray, state: np.ndarray, byte: int) -> None:
    if state[OUT] < len(out):
        out[state[OUT]] = byte
    state[OUT] += 1


@njit(cache=True)
def _shift_low(state: np.ndarray, out: np.ndarray) -> None:
    low = state[LOW]
    if low < 0xFF000000 or low > MASK32:
        carry = low >> 32
        if state[FIRST]:
            state[FIRST] = 0          # the first byte is always 0: not stored
        else:
            _put(out, state, (state[CACHE] + carry) & 0xFF)
        for _ in range(state[PENDING]):
            _put(out, state, (0xFF + carry) & 0xFF)
        state[PENDING] = 0
        state[CACHE] = (low >> 24) & 0xFF
    else:
        state[PENDING] += 1
    state[LOW] = (low << 8) & MASK32


@njit(cache=True)
def _next_byte(state: np.ndarray, data: np.ndarray) -> int:
    pos = state[POS]
    state[POS] = pos + 1
    if pos < len(data):
        return np.int64(data[pos])
    state[OVER] += 1
    return 0


@njit(cache=True)
def _encode_bit(state: np.ndarray, out: np.ndarray, p: int, bit: int) -> None:
    """The range coder's encoding step: `bit` with P(0) = p / 65536, then renormalisation."""
    rng = state[RANGE]
    bound = (rng >> PROB_BITS) * p
    if bit == 0:
        state[RANGE] = bound
    else:
        state[LOW] += bound
        state[RANGE] = rng - bound
    while state[RANGE] < TOP:
        state[RANGE] = (state[RANGE] << 8) & MASK32
        _shift_low(state, out)


@njit(cache=True)
def _decode_bit(state: np.ndarray, data: np.ndarray, p: int) -> int:
    """The range coder's decoding step with P(0) = p / 65536, then renormalisation; returns the bit."""
    rng = state[DRANGE]
    bound = (rng >> PROB_BITS) * p
    if state[CODE] < bound:
        state[DRANGE] = bound
        bit = 0
    else:
        state[CODE] -= bound
        state[DRANGE] = rng - bound
        bit = 1
    while state[DRANGE] < TOP:
        state[DRANGE] = (state[DRANGE] << 8) & MASK32
        state[CODE] = ((state[CODE] << 8) | _next_byte(state, data)) & MASK32
    return bit


@njit(cache=True)
def _adapt(probs: np.ndarray, counts: np.ndarray, ctx: int, bit: int) -> None:
    """Moves context ctx's P(0) towards the coded bit (see the module docstring)."""
    p = probs[ctx]
    n = counts[ctx]
    target = 0 if bit else PROB_ONE
    if n + 2 < (1 << RATE_SHIFT):
        p += (target - p) // (n + 2)
        counts[ctx] = n + 1
    else:
        p += (target - p) >> RATE_SHIFT
    probs[ctx] = min(max(p, PROB_MIN), PROB_ONE - PROB_MIN)


@njit(cache=True)
def _code_bit(decoding: bool, state: np.ndarray, buf: np.ndarray, probs: np.ndarray, counts: np.ndarray,
              tally: np.ndarray, ctx: int, bit: int) -> int:
    """Encodes `bit` (or decodes and returns one) with context ctx (ctx < 0: P = 1/2, no adaptation); with a
    non-empty tally (n_contexts, 2), counts the coded bit there (training, tools/train_context_priors.py)."""
    p = PROB_ONE >> 1 if ctx < 0 else probs[ctx]
    if decoding:
        bit = _decode_bit(state, buf, p)
    else:
        _encode_bit(state, buf, p, bit)
    if ctx >= 0:
        if len(tally):
            tally[ctx, bit] += 1
        _adapt(probs, counts, ctx, bit)
    return bit


@njit(cache=True)
def _bit_length(m: int) -> int:
    n = 0
    while m >> n:
        n += 1
    return n


@njit(cache=True)
def _band(position: int, block: int) -> int:
    if position == 0:
        return 0 if block == 0 else 1
    return 1 + _bit_length(position)      # positions 1 / 2-3 / 4-7 / 8-15 -> bands 2 / 3 / 4 / 5


@njit(cache=True)
def _sign3(v: int) -> int:
    return 0 if v < 0 else (1 if v == 0 else 2)


@njit(cache=True)
def _code_value(decoding: bool, state, buf, probs, counts, tally, band: int, pc: int, sign_ctx: int, value: int) -> int:
    magnitude = -value if value < 0 else value
    k = _bit_length(magnitude)
    got = 0
    for j in range(MAX_CLASS):
        rel = min(max(j - pc, -3), 3) + 3
        pcb = 0 if pc == 0 else (1 if pc < 3 else (2 if pc < 6 else 3))
        ctx = ((band * REL + rel) * PCB + pcb) * 2 + (1 if j > 0 else 0)
        if _code_bit(decoding, state, buf, probs, counts, tally, ctx, 1 if k > j else 0) == 0:
            break
        got = j + 1
    if decoding:
        k = got
    if k == 0:
        return 0
    negative = _code_bit(decoding, state, buf, probs, counts, tally, SIGN_BASE + band * 9 + sign_ctx,
                           1 if value < 0 else 0)
    result = 1
    for i in range(k - 2, -1, -1):
        ctx = MANTISSA_BASE + k if i == k - 2 else (MANTISSA2_BASE + k if i == k - 3 else -1)
        result = (result << 1) | _code_bit(decoding, state, buf, probs, counts, tally, ctx, (magnitude >> i) & 1)
    return -result if negative else result


@njit(cache=True)
def _run(decoding: bool, coeffs: np.ndarray, state: np.ndarray, buf: np.ndarray, probs: np.ndarray,
         counts: np.ndarray, tally: np.ndarray) -> None:
    n_dofs, n_blocks, _ = coeffs.shape
    for d in range(n_dofs):
        for b in range(n_blocks):
            for i in range(BLOCK):
                if i == 0:
                    previous = coeffs[d, b - 1, 0] if b > 0 else 0
                    parent = 0
                else:
                    width = 1 << (_bit_length(i) - 1)
                    if i > width:
                        previous = coeffs[d, b, i - 1]
                    else:
                        previous = coeffs[d, b - 1, 2 * width - 1] if b > 0 else 0
                    parent = coeffs[d, b, i >> 1] if i > 1 else 0
                sign_ctx = 3 * _sign3(previous) + _sign3(parent)
                parent = -parent if parent < 0 else parent
                previous = -previous if previous < 0 else previous
                pc = _bit_length(2 * previous + parent)
                value = _code_value(decoding, state, buf, probs, counts, tally, _band(i, b), pc, sign_ctx, coeffs[d, b, i])
                if decoding:
                    coeffs[d, b, i] = value
            if decoding and state[OVER] > MAX_OVERRUN:
                return      # read past the payload: damaged (finish_decoder says so), and a crafted frame count
                # must not make the decoder run through millions of coefficients of padding


@njit(cache=True)
def encode(coeffs: np.ndarray, out: np.ndarray) -> int:
    """The b"C" section's payload: coeffs (D, n_blocks, 16) int64 (|v| < 2^MAX_CLASS) with untrained models into
    out (a compact payload without a mask); returns the payload length (more than len(out): call again with that
    many bytes), or -1 when a value is too large."""
    probs, counts = uniform_models(N_CONTEXTS)
    no_mask = np.zeros(0, dtype=np.int64)
    return encode_payload(no_mask, coeffs, no_mask, no_mask, probs, counts, out)


@njit(cache=True)
def decode(data: np.ndarray, coeffs: np.ndarray) -> int:
    """Fills coeffs (D, n_blocks, 16) int64 from the b"C" section's payload `data`; 0, or -1 when the payload is
    damaged (read past its end by more than MAX_OVERRUN bytes, or not ending where the coefficients do)."""
    state = decoder_state(data)
    probs, counts = uniform_models(N_CONTEXTS)
    decode_coefficients(state, data, coeffs, probs, counts)
    return finish_decoder(state, data)


# ---------------------------------------------------------------- one payload in steps (the compact framing)
# ContextWaveletCoder's compact streams code the active-DOF mask and then the coefficients in one payload,
# with models that start from trained states: the decoder learns the number of active DOFs from the mask
# before it sizes the coefficient array, so the payload is coded in steps on one coder state.

@njit(cache=True)
def uniform_models(n_contexts: int) -> tuple[np.ndarray, np.ndarray]:
    """(probs, counts) (n_contexts,) int64 of untrained models: P(0) = 1/2, no bit seen."""
    return np.full(n_contexts, PROB_ONE >> 1, dtype=np.int64), np.zeros(n_contexts, dtype=np.int64)


@njit(cache=True)
def encoder_state() -> np.ndarray:
    state = np.zeros(6, dtype=np.int64)
    state[RANGE] = MASK32
    state[FIRST] = 1
    return state


@njit(cache=True)
def finish_encoder(state: np.ndarray, out: np.ndarray) -> int:
    """Flushes the encoder; returns the payload length (more than len(out): code again into that many bytes)."""
    for _ in range(5):
        _shift_low(state, out)
    return state[OUT]


@njit(cache=True)
def decoder_state(data: np.ndarray) -> np.ndarray:
    state = np.zeros(4, dtype=np.int64)
    state[DRANGE] = MASK32
    for _ in range(4):
        state[CODE] = (state[CODE] << 8) | _next_byte(state, data)
    return state


@njit(cache=True)
def finish_decoder(state: np.ndarray, data: np.ndarray) -> int:
    """0 when the decoder stopped exactly at the payload's end (within MAX_OVERRUN), else -1."""
    if state[OVER] > MAX_OVERRUN or state[POS] != len(data):
        return -1
    return 0


@njit(cache=True)
def code_mask(decoding: bool, state: np.ndarray, buf: np.ndarray, mask: np.ndarray, probs: np.ndarray,
              counts: np.ndarray, tally: np.ndarray) -> None:
    """The active-DOF mask (D,) int64 of 0/1, one bin per DOF; context 2 d + (DOF d - 1 active), so probs,
    counts have 2 D entries. Decoding fills mask."""
    previous = 0
    for d in range(len(mask)):
        bit = _code_bit(decoding, state, buf, probs, counts, tally, 2 * d + previous, mask[d])
        if decoding:
            mask[d] = bit
        previous = bit


@njit(cache=True)
def code_coefficients(decoding: bool, state: np.ndarray, buf: np.ndarray, coeffs: np.ndarray, probs: np.ndarray,
                      counts: np.ndarray, tally: np.ndarray) -> int:
    """Codes (or, decoding, fills) coeffs (D, n_blocks, 16) int64 with models probs, counts (N_CONTEXTS,)
    (updated in place); -1 when encoding a value of 2^MAX_CLASS or more, else 0."""
    if not decoding:
        limit = np.int64(1) << MAX_CLASS
        for v in coeffs.ravel():
            if v >= limit or v <= -limit:
                return -1
    _run(decoding, coeffs, state, buf, probs, counts, tally)
    return 0


# The coder's own entry points: `decoding` a literal in each, so that the compiler drops the other end's branches.

@njit(cache=True)
def encode_payload(mask: np.ndarray, coeffs: np.ndarray, mask_probs: np.ndarray, mask_counts: np.ndarray,
                   probs: np.ndarray, counts: np.ndarray, out: np.ndarray) -> int:
    """The compact payload: mask (D,) 0/1 then coeffs (n_active, n_blocks, 16) from the given initial models
    (updated in place) into out; returns its length (more than len(out): code again into that many bytes), or -1
    when a coefficient is 2^MAX_CLASS or more."""
    state = encoder_state()
    no_tally = np.zeros((0, 2), dtype=np.int64)
    code_mask(False, state, out, mask, mask_probs, mask_counts, no_tally)
    if code_coefficients(False, state, out, coeffs, probs, counts, no_tally) != 0:
        return -1
    return finish_encoder(state, out)


@njit(cache=True)
def decode_mask(state: np.ndarray, data: np.ndarray, mask: np.ndarray, probs: np.ndarray, counts: np.ndarray) -> None:
    code_mask(True, state, data, mask, probs, counts, np.zeros((0, 2), dtype=np.int64))


@njit(cache=True)
def decode_coefficients(state: np.ndarray, data: np.ndarray, coeffs: np.ndarray, probs: np.ndarray,
                        counts: np.ndarray) -> None:
    code_coefficients(True, state, data, coeffs, probs, counts, np.zeros((0, 2), dtype=np.int64))
