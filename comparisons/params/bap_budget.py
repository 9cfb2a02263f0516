"""Bit budget of an FBA body stream per BAP group: where the bits of a coded motion go.

Method (attribution by encoding each group alone): a motion's BAP values (T, 296) are coded with
comparisons.params.fba.encode_fba (real coded bytes, CRC included, no estimate) three ways:
- with every BAP zero: the shared overhead any stream of that length and frame rate pays (object and
  plane start codes, plane headers, group masks, the CRC);
- with only group g's BAPs kept (bap_table.GROUP_MEMBERS; all others 0): group g costs
  bits(group g only) - bits(no group);
- with all groups: the stream that is sent (the total).
The overhead and the groups' costs need not add up to the total: the coder's choices depend on the
whole plane (where intra planes fall, the one-frame intra plane for values that jump once and hold,
range fields shared in a plane), so the remainder is reported as `interaction_bits` (total -
overhead - sum of groups; negative when groups coded together share a cost each pays alone).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from media.domain import kbps
from comparisons.params import bap_table
from comparisons.params.fba import encode_fba
from comparisons.params.fba_mapping import motion_to_baps
from media.errors import SigncastError
from media.motion import Motion


@dataclass(frozen=True)
class GroupBudget:
    """Bits of one coded BAP stream. coding: 'pred' or 'dct'; q: global quantisation 1..31; fps;
    n_frames; total_bits: the stream with every group; overhead_bits: the stream with none;
    group_bits: group id (1..24) -> bits(that group alone) - overhead_bits, for every group with a
    non-zero value."""
    coding: str
    q: int
    fps: float
    n_frames: int
    total_bits: int
    overhead_bits: int
    group_bits: dict[int, int] = field(default_factory=dict)

    @property
    def duration_s(self) -> float:
        return self.n_frames / self.fps

    @property
    def interaction_bits(self) -> int:
        """total - overhead - sum of the groups' bits (see the module docstring)."""
        return self.total_bits - self.overhead_bits - sum(self.group_bits.values())

    def kbps(self, bits: float) -> float:
        """bits over the stream's duration, kbit/s."""
        return kbps(bits, self.duration_s)

    def group_kbps(self) -> dict[int, float]:
        """group id -> kbit/s (groups with a non-zero value)."""
        return {group: self.kbps(bits) for group, bits in self.group_bits.items()}


def group_label(group: int) -> str:
    """Descriptive label of BAP group 1..24 (bap_table.GROUP_LABELS)."""
    if not 1 <= group <= bap_table.N_GROUPS:
        raise SigncastError(f"BAP groups are 1..{bap_table.N_GROUPS}, not {group}")
    return bap_table.GROUP_LABELS[group - 1]


def stream_bits(values: np.ndarray, fps: float, q: int, coding: str) -> int:
    """Size in bits of the FBA body stream of BAP values (T, 296) int64."""
    return 8 * len(encode_fba(values, fps, q, coding))


def group_budget(values: np.ndarray, fps: float, q: int, coding: str) -> GroupBudget:
    """The bit budget per BAP group of BAP values (T, 296) int64 at `fps`, coded with `coding`
    ('pred' or 'dct') at global quantisation q (module docstring: the method)."""
    values = np.asarray(values)
    if values.ndim != 2 or values.shape[1] != bap_table.N_BAPS or len(values) == 0:
        raise SigncastError(f"BAP values must be (T, {bap_table.N_BAPS}) with T >= 1, got {values.shape}")
    overhead = stream_bits(np.zeros_like(values), fps, q, coding)
    groups = {}
    for group, members in enumerate(bap_table.GROUP_MEMBERS, start=1):
        columns = np.array(members) - 1
        if not values[:, columns].any():
            continue
        alone = np.zeros_like(values)
        alone[:, columns] = values[:, columns]
        groups[group] = stream_bits(alone, fps, q, coding) - overhead
    return GroupBudget(coding, int(q), float(fps), len(values), stream_bits(values, fps, q, coding), overhead, groups)


def motion_group_budget(motion: Motion, q: int, coding: str) -> GroupBudget:
    """group_budget of a Motion's BAPs (comparisons.params.fba_mapping.motion_to_baps; body only: a face's
    FAPs are not coded here)."""
    return group_budget(motion_to_baps(motion), motion.fps, q, coding)
