"""The motion-coding laboratory of seed 002 as Motion codecs: Motion -> DOFs (T, D) -> bytes -> DOFs -> Motion.

DOFs are the avatar's rotation BAPs (comparisons/params/fba_mapping.py: flexion, abduction, twist per bone,
radians) of the signing bones: spine, neck, head, both arms and both hands (legs, pelvis and the
root do not sign). Joint groups (seed 002 table 6-1, minus the legs): torso_head, left_arm,
left_hand, right_arm, right_hand. DOF ranges (the quantiser limits, the role the joint limits play
in seed 002) are measured on the training split of the lexicon and shipped in
comparisons/tables/lab_dof_ranges.npz with the codebooks.

A coded clip is b"SCL1" | coder id (u8) | active-DOF mask (ceil(D/8) bytes) | inner stream | CRC-32:
DOFs that stay exactly 0 (the rest pose) in the clip are not coded, the others go to the coder.
A coder whose class says `framing = "compact"` (wavelet-cx) writes the whole clip itself instead, mask included,
in the compact layout of comparisons/lab/streams.write_compact (b"Sc" ... CRC-32, ~10 bytes of framing in
place of ~58): `encode_compact(active dofs, fps, index, mask)` and `decode_compact(bytes, D)`.
Both ends bound the clip to T x D <= streams.MAX_VALUES with D the whole layout (the decoder's
output size), before coding or allocating anything.

LabCodec: encode(Motion, q) -> bytes and decode(bytes) -> Motion (the Motion codec interface of
comparisons/params/codecs.py); encode_dofs((T, D) radians, fps, index) -> (bytes, (T, D) reconstruction) and
decode_dofs(bytes) -> ((T, D) radians, fps) on the layout's DOFs; decode_levels(bytes) -> the integers the
stream carries (the decoder's exact part, pinned by tests/data/conformance/lab/). Errors: SigncastError for an
unknown coder, a q outside 1..len(settings()), DOFs of the wrong shape, and any damaged or foreign stream.
"""
from __future__ import annotations

import functools
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from comparisons.params import bap_table
from comparisons.lab.streams import DEFAULT_STAGE, StreamReader, check_size
from comparisons.params.fba_mapping import avatar_bap_map, baps_to_motion, motion_to_baps
from comparisons.lab.settings import EVALUATION_LANGUAGES, MPEG4_Q
from comparisons.lab.model import (GestureCoder, HybridCoder, PostureCoder, gesture_coder, hybrid_coder,
                                      load_model_tables, posture_coder)
from comparisons.lab.vq import (TABLES_DIR, SpatialVQ, TemporalVQ, load_vq_tables, spatial_vq,
                                             temporal_vq)
from comparisons.lab.waveform import WAVEFORM_CODERS, DofCoder
from media.domain import MODEL_NAMES, MOTION_CODER_NAMES, WAVEFORM_NAMES  # noqa: F401  (re-exported)
from media.errors import SigncastError
from media.motion import Motion

RANGES_PATH = TABLES_DIR / "lab_dof_ranges.npz"
MAGIC = b"SCL1"
NOT_SIGNING = {"root", "pelvis", "upperleg01", "upperleg02", "lowerleg01", "lowerleg02", "foot", "toe1-1"}
HAND_BONES = ("finger", "metacarpal")
ARM_BONES = ("clavicle", "shoulder01", "upperarm", "lowerarm", "wrist")
LAB_CODEC_NAMES = MOTION_CODER_NAMES           # WAVEFORM_NAMES + MODEL_NAMES (media.domain)
CODER_CLASSES = {**WAVEFORM_CODERS, "svq": SpatialVQ, "tvq": TemporalVQ, "posture": PostureCoder,
                 "gesture": GestureCoder, "hybrid": HybridCoder}
# each coder's id in its streams' headers is the class's own, so listing a new coder anywhere keeps old streams
CODER_IDS = {name: CODER_CLASSES[name].coder_id for name in LAB_CODEC_NAMES}


@dataclass(frozen=True)
class DofLayout:
    """names (D,): BAP names; bap_ids (D,): 1-based BAP ids; groups: {group: DOF indices}."""
    names: tuple[str, ...]
    bap_ids: np.ndarray
    groups: dict[str, np.ndarray]

    @property
    def n_dofs(self) -> int:
        return len(self.names)


def _group_of(bone: str) -> str:
    base, _, side = bone.partition(".")
    side = {"L": "left", "R": "right"}.get(side)
    if side and base.startswith(HAND_BONES):
        return f"{side}_hand"
    if side and base.startswith(ARM_BONES):
        return f"{side}_arm"
    if side is None:
        return "torso_head"
    raise SigncastError(f"bone {bone} belongs to no signing group")


@functools.lru_cache(maxsize=1)
def dof_layout() -> DofLayout:
    bap_map = avatar_bap_map()
    names, ids, groups = [], [], {}
    for bone in bap_map.bones:
        if bone.bone.partition(".")[0] in NOT_SIGNING:
            continue
        group = _group_of(bone.bone)
        for bap_id in bone.baps:
            groups.setdefault(group, []).append(len(names))
            names.append(bap_table.bap(bap_id).name)
            ids.append(bap_id)
    return DofLayout(tuple(names), np.array(ids), {g: np.array(v) for g, v in groups.items()})


def motion_dofs(motion: Motion) -> np.ndarray:
    """(T, D) radians: the signing DOFs of a Motion on the avatar."""
    baps = motion_to_baps(motion)
    return baps[:, dof_layout().bap_ids - 1].astype(np.float64) * bap_table.ROTATION_UNIT_RAD


def dofs_motion(dofs: np.ndarray, fps: float) -> Motion:
    """Motion of the avatar's mapped bones from (T, D) signing DOFs (every other BAP at 0)."""
    layout = dof_layout()
    values = np.zeros((len(dofs), bap_table.N_BAPS), dtype=np.int64)
    values[:, layout.bap_ids - 1] = np.rint(np.asarray(dofs) / bap_table.ROTATION_UNIT_RAD).astype(np.int64)
    return baps_to_motion(values, fps)


@functools.lru_cache(maxsize=1)
def dof_ranges(path: Path = RANGES_PATH) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) (D,) radians of the layout, from the shipped table."""
    try:
        with np.load(path, allow_pickle=False) as table:
            names, lower, upper = [str(n) for n in table["names"]], table["lower"], table["upper"]
    except OSError:
        raise SigncastError(f"DOF ranges missing ({path}): run tools/train_vq_codebooks.py") from None
    if tuple(names) != dof_layout().names:
        raise SigncastError("the shipped DOF ranges do not match the avatar's DOF layout: retrain the tables")
    return lower.astype(np.float64), upper.astype(np.float64)


@functools.lru_cache(maxsize=1)
def _tables() -> tuple[dict, dict]:
    return load_vq_tables(), load_model_tables()


def make_coder(name: str, active: np.ndarray, stage: str | None = None) -> DofCoder:
    """The coder `name` over the active DOFs (bool mask (D,)) of the layout. Coders hold no state between
    clips, so one is kept per (name, mask, stage): building one cuts its tables to the active DOFs."""
    return _cached_coder(name, np.asarray(active, dtype=bool).tobytes(), stage)


@functools.lru_cache(maxsize=256)
def _cached_coder(name: str, active_bytes: bytes, stage: str | None) -> DofCoder:
    return _build_coder(name, np.frombuffer(active_bytes, dtype=bool), stage)


def _build_coder(name: str, active: np.ndarray, stage: str | None) -> DofCoder:
    lower, upper = dof_ranges()
    names = [n for n, a in zip(dof_layout().names, active) if a]
    lower, upper = lower[active], upper[active]
    if name in WAVEFORM_CODERS:
        return WAVEFORM_CODERS[name](lower, upper, stage=stage)
    vq, model = _tables()
    builders = {
        "svq": lambda: spatial_vq(lower, upper, names, vq, stage),
        "tvq": lambda: temporal_vq(lower, upper, vq, stage),
        "posture": lambda: posture_coder(lower, upper, names, model, stage),
        "gesture": lambda: gesture_coder(lower, upper, names, model, stage),
        "hybrid": lambda: hybrid_coder(lower, upper, names, model, stage),
    }
    if name not in builders:
        raise SigncastError(f"unknown motion coder {name!r}; choose from {', '.join(LAB_CODEC_NAMES)}")
    return builders[name]()


DESCRIPTIONS = {
    "quant": "direct uniform quantisation per DOF (levels)",
    "nuquant": "mu-law companded quantisation per DOF (levels)",
    "dpcm": "first-order DPCM, mu-law difference quantiser (levels)",
    "adpcm": "adaptive predictive coding, order 2, Jayant-adapted quantiser (levels)",
    "deadreck": "dead reckoning, constant-velocity extrapolation (threshold, degrees)",
    "dct": "16-sample DCT blocks, Appendix III bit allocations",
    "wavelet": "Haar wavelet of 16-sample blocks (step, rad)",
    "wavelet-cx": "Haar wavelet of 16-sample blocks, context-modelled binary coding (step, rad)",
    "svq": "spatial VQ per joint group (codebook size)",
    "tvq": "temporal VQ of 6-sample blocks, closed loop (codebook size)",
    "posture": "posture segmentation + posture table + Hermite interpolation (distance d, rad)",
    "gesture": "gesture segmentation + gesture table, posture fallback (segmentation density)",
    "hybrid": "gesture segmentation + 3 DCT coefficients per segment (bit allocation)",
}


class LabCodec:
    """One seed-002 coder as a Motion codec for comparisons/params/codecs.py:
    encode(motion, q) -> bytes, decode(bytes) -> Motion, with q = 1 .. len(settings()) the
    operating point (1 = lowest rate), as the MPEG-4 codecs' Q is an integer knob. The coders carry the
    signing DOFs (`dof_layout`) only: a motion's face (FAPs) and root translation decode at rest."""

    sends_face = False

    def __init__(self, name: str, stage: str = DEFAULT_STAGE):
        if name not in CODER_IDS:
            raise SigncastError(f"unknown motion coder {name!r}; choose from {', '.join(LAB_CODEC_NAMES)}")
        self.name = name
        self.stage = stage
        self.description = f"seed 002: {DESCRIPTIONS[name]}"
        self.quality_measure = "vpsnr" if name in MODEL_NAMES else "psnr"
        self.compact = getattr(CODER_CLASSES[name], "framing", "container") == "compact"

    def settings(self) -> tuple:
        """The coder's operating points, q = 1 .. len()."""
        return CODER_CLASSES[self.name].settings

    def index_of(self, q: int) -> int:
        settings = self.settings()
        if not (isinstance(q, (int, np.integer)) and 1 <= q <= len(settings)):
            raise SigncastError(f"{self.name}: q must be 1..{len(settings)} "
                                f"({', '.join(f'{k + 1}={v}' for k, v in enumerate(settings))}), got {q!r}")
        return int(q) - 1

    def encode_dofs(self, dofs: np.ndarray, fps: float, index: int) -> tuple[bytes, np.ndarray]:
        """(T, D) layout DOFs at operating point `index` (0-based) -> (bytes, the decoder's (T, D))."""
        dofs = np.asarray(dofs, dtype=np.float64)
        layout = dof_layout()
        if dofs.ndim != 2 or dofs.shape[1] != layout.n_dofs:
            raise SigncastError(f"{self.name}: DOFs must be (T, {layout.n_dofs}), got {dofs.shape}")
        check_size(len(dofs), layout.n_dofs, f"{self.name}: cannot code")
        active = np.any(dofs != 0.0, axis=0)
        if not active.any():
            active[0] = True  # a clip of pure rest pose still needs one coded DOF to carry T and fps
        coder = make_coder(self.name, active, self.stage)
        if self.compact:
            data, recon_active = coder.encode_compact(dofs[:, active], fps, index, active)
            recon = np.zeros_like(dofs)
            recon[:, active] = recon_active
            return data, recon
        inner, recon_active = coder.encode(dofs[:, active], fps, index)
        body = MAGIC + bytes([CODER_IDS[self.name]]) + np.packbits(active).tobytes() + inner
        recon = np.zeros_like(dofs)
        recon[:, active] = recon_active
        return body + struct.pack("<I", zlib.crc32(body)), recon

    def decode_levels(self, data: bytes) -> tuple[dict[str, np.ndarray], np.ndarray, int, float]:
        """The decoder's exact part: bytes -> (the integers the coder sent for the active DOFs, before
        dequantisation ({name: int64 array}, the coder's `_read` names them), active mask (D,) bool of the layout,
        frames T, fps). Conformance streams pin these (tests/test_lab_conformance.py). SigncastError on damage."""
        data = bytes(data)
        layout = dof_layout()
        if self.compact:
            indices, active, stream = CODER_CLASSES[self.name].read_compact_levels(data, layout.n_dofs)
            return {"indices": indices}, active, stream.n_frames, stream.fps
        active, inner = self._unwrap(data)
        levels, info = make_coder(self.name, active, self.stage).read_levels(inner)
        return levels, active, info.n_frames, info.fps

    def _unwrap(self, data: bytes) -> tuple[np.ndarray, bytes]:
        """An SCL1 stream -> (active mask (D,) bool, the inner SCM1 stream), checked and bounded."""
        layout = dof_layout()
        mask_bytes = -(-layout.n_dofs // 8)
        if len(data) < 5 + mask_bytes + 4 or data[:4] != MAGIC:
            raise SigncastError(f"not a {self.name} motion stream (bad magic or truncated)")
        body, (crc,) = data[:-4], struct.unpack("<I", data[-4:])
        if zlib.crc32(body) != crc:
            raise SigncastError(f"corrupt {self.name} motion stream: checksum mismatch")
        if body[4] != CODER_IDS[self.name]:
            raise SigncastError(f"{self.name} decoder got a stream of another coder (id {body[4]})")
        active = np.unpackbits(np.frombuffer(body[5:5 + mask_bytes], np.uint8))[:layout.n_dofs].astype(bool)
        if not active.any():
            raise SigncastError(f"corrupt {self.name} motion stream: no active DOF")
        inner = body[5 + mask_bytes:]
        frames = StreamReader(inner, CODER_IDS[self.name], self.name).info.n_frames
        check_size(frames, layout.n_dofs, f"corrupt {self.name} motion stream")
        return active, inner

    def decode_dofs(self, data: bytes) -> tuple[np.ndarray, float]:
        """Bytes -> ((T, D) radians of the whole layout, fps); SigncastError on damage."""
        data = bytes(data)
        layout = dof_layout()
        if self.compact:
            recon_active, active, fps = CODER_CLASSES[self.name].decode_compact(data, layout.n_dofs)
            recon = np.zeros((len(recon_active), layout.n_dofs))
            recon[:, active] = recon_active
            return recon, fps
        active, inner = self._unwrap(data)
        recon_active, fps = make_coder(self.name, active, self.stage).decode_with_fps(inner)
        recon = np.zeros((len(recon_active), layout.n_dofs))
        recon[:, active] = recon_active
        return recon, fps

    def encode(self, motion: Motion, q: int) -> bytes:
        return self.encode_dofs(motion_dofs(motion), motion.fps, self.index_of(q))[0]

    def decode(self, data: bytes) -> Motion:
        dofs, fps = self.decode_dofs(data)
        return dofs_motion(dofs, fps)


def lab_codecs() -> list[LabCodec]:
    """The twelve coders, for registration in comparisons/params/codecs.py."""
    return [LabCodec(name) for name in LAB_CODEC_NAMES]




def alphabet_motion(language: str, fps: float = 25.0) -> Motion:
    """The language's whole alphabet fingerspelled in lexicon order: the long test sequence."""
    from media import lexicon
    from media.fingerspelling import fingerspell
    return fingerspell(language, "".join(lexicon.units(language)), fps)


def training_languages() -> list[str]:
    from media import lexicon
    return [language for language in lexicon.languages() if language not in EVALUATION_LANGUAGES]


def codec_qs(name: str, qs: tuple[int, ...] | None) -> tuple[int, ...]:
    """The Q values --param-q gives codec name, the same in params, lab and compare: qs for FBA/BBA; for a seed-002
    coder, whose q is its operating point 1..N (1 = lowest rate), those of qs up to N (qs None: all N)."""
    if name not in WAVEFORM_NAMES + MODEL_NAMES:
        return tuple(MPEG4_Q if qs is None else qs)
    count = len(LabCodec(name).settings())
    return tuple(range(1, count + 1)) if qs is None else tuple(q for q in qs if 1 <= q <= count)


def check_codec_qs(codecs, qs: tuple[int, ...] | None) -> None:
    """Refuse a --param-q that leaves a codec nothing to measure."""
    for name in codecs:
        if not codec_qs(name, qs):
            count = len(LabCodec(name).settings())
            raise SigncastError(f"--param-q {','.join(map(str, qs))} holds none of {name}'s operating points 1..{count} "
                                f"(a seed-002 coder's q is its operating point, 1 = lowest rate)")
