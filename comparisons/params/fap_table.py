"""The MPEG-4 FAP set: 68 facial animation parameters (ids 1..68), their units, groups and steps.

Sources:
- ids, names, units (FAPU), uni/bidirectional, direction of positive motion and group (1..10):
  ISO/IEC 14496-2 Annex C "FAP definitions, group assignments and step sizes", as restated in public
  face-animation code (e.g. Cal3D-based `Mpeg4FAPDesc` tables, Greta `FAPType.java`); seed 000 Table
  3.3 counts "68 for face".
- quantisation step (FAP_QP): the same Annex C table as recalled for this project. The readable public
  sources do not print it, so the steps are marked UNVERIFIED in ../shared/notes (mpeg4-facts.md §1.7:
  `qstep = FAP_QP[i] * fap_quant`, a linear scale, unlike BAPs' bap_pred_scale).

Units: FAPU = a neutral-face distance / 1024 (`FAPU_NAMES`), or AU = 1e-5 rad for rotations
(head, eyeballs, tongue roll). The high-level FAPs 1 (viseme) and 2 (expression) carry a
structure, not one number; signcast never sends them (docs/face.md) and codes groups 2..10.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

N_FAPS = 68
N_GROUPS = 10
ANGLE_UNIT_RAD = 1e-5
FAPU_DIVISOR = 1024
# FAPU measured on the neutral face (ISO/IEC 14496-2 §6.3.11.3 Table C-1, Fig. C-1):
FAPU_NAMES = {
    "IRISD": "iris diameter: upper to lower eyelid of the neutral open eye",
    "ES": "eye separation: distance between the pupils",
    "ENS": "eye-nose separation: eyes' line to the nose tip",
    "MNS": "mouth-nose separation: nose tip to the mouth's middle",
    "MW": "mouth width: corner to corner",
    "AU": "angle unit, 1e-5 rad",
}


@dataclass(frozen=True)
class Fap:
    """One FAP: id 1..68, name, unit (a FAPU_NAMES key), bidirectional (False: only positive
    values make sense), direction of positive motion, group 1..10, quantisation step (FAP units)."""
    id: int
    name: str
    unit: str
    bidirectional: bool
    direction: str
    group: int
    step: int


_TABLE = [
    # id, name, unit, bidirectional, positive motion, group, step
    (1, "viseme", "-", False, "-", 1, 1),
    (2, "expression", "-", False, "-", 1, 1),
    (3, "open_jaw", "MNS", False, "down", 2, 4),
    (4, "lower_t_midlip", "MNS", True, "down", 2, 2),
    (5, "raise_b_midlip", "MNS", True, "up", 2, 2),
    (6, "stretch_l_cornerlip", "MW", True, "left", 2, 2),
    (7, "stretch_r_cornerlip", "MW", True, "right", 2, 2),
    (8, "lower_t_lip_lm", "MNS", True, "down", 2, 2),
    (9, "lower_t_lip_rm", "MNS", True, "down", 2, 2),
    (10, "raise_b_lip_lm", "MNS", True, "up", 2, 2),
    (11, "raise_b_lip_rm", "MNS", True, "up", 2, 2),
    (12, "raise_l_cornerlip", "MNS", True, "up", 2, 2),
    (13, "raise_r_cornerlip", "MNS", True, "up", 2, 2),
    (14, "thrust_jaw", "MNS", False, "forward", 2, 1),
    (15, "shift_jaw", "MW", True, "right", 2, 1),
    (16, "push_b_lip", "MNS", True, "forward", 2, 1),
    (17, "push_t_lip", "MNS", True, "forward", 2, 1),
    (18, "depress_chin", "MNS", True, "up", 2, 1),
    (19, "close_t_l_eyelid", "IRISD", True, "down", 3, 1),
    (20, "close_t_r_eyelid", "IRISD", True, "down", 3, 1),
    (21, "close_b_l_eyelid", "IRISD", True, "up", 3, 1),
    (22, "close_b_r_eyelid", "IRISD", True, "up", 3, 1),
    (23, "yaw_l_eyeball", "AU", True, "left", 3, 128),
    (24, "yaw_r_eyeball", "AU", True, "left", 3, 128),
    (25, "pitch_l_eyeball", "AU", True, "down", 3, 128),
    (26, "pitch_r_eyeball", "AU", True, "down", 3, 128),
    (27, "thrust_l_eyeball", "ES", True, "forward", 3, 1),
    (28, "thrust_r_eyeball", "ES", True, "forward", 3, 1),
    (29, "dilate_l_pupil", "IRISD", True, "growing", 3, 1),
    (30, "dilate_r_pupil", "IRISD", True, "growing", 3, 1),
    (31, "raise_l_i_eyebrow", "ENS", True, "up", 4, 2),
    (32, "raise_r_i_eyebrow", "ENS", True, "up", 4, 2),
    (33, "raise_l_m_eyebrow", "ENS", True, "up", 4, 2),
    (34, "raise_r_m_eyebrow", "ENS", True, "up", 4, 2),
    (35, "raise_l_o_eyebrow", "ENS", True, "up", 4, 2),
    (36, "raise_r_o_eyebrow", "ENS", True, "up", 4, 2),
    (37, "squeeze_l_eyebrow", "ES", True, "right", 4, 1),
    (38, "squeeze_r_eyebrow", "ES", True, "left", 4, 1),
    (39, "puff_l_cheek", "ES", True, "left", 5, 2),
    (40, "puff_r_cheek", "ES", True, "right", 5, 2),
    (41, "lift_l_cheek", "ENS", False, "up", 5, 2),
    (42, "lift_r_cheek", "ENS", False, "up", 5, 2),
    (43, "shift_tongue_tip", "MW", True, "right", 6, 1),
    (44, "raise_tongue_tip", "MNS", True, "up", 6, 1),
    (45, "thrust_tongue_tip", "MW", True, "forward", 6, 1),
    (46, "raise_tongue", "MNS", True, "up", 6, 1),
    (47, "tongue_roll", "AU", False, "concave upward", 6, 512),
    (48, "head_pitch", "AU", True, "down", 7, 170),
    (49, "head_yaw", "AU", True, "left", 7, 170),
    (50, "head_roll", "AU", True, "right", 7, 170),
    (51, "lower_t_midlip_o", "MNS", True, "down", 8, 2),
    (52, "raise_b_midlip_o", "MNS", True, "up", 8, 2),
    (53, "stretch_l_cornerlip_o", "MW", True, "left", 8, 2),
    (54, "stretch_r_cornerlip_o", "MW", True, "right", 8, 2),
    (55, "lower_t_lip_lm_o", "MNS", True, "down", 8, 2),
    (56, "lower_t_lip_rm_o", "MNS", True, "down", 8, 2),
    (57, "raise_b_lip_lm_o", "MNS", True, "up", 8, 2),
    (58, "raise_b_lip_rm_o", "MNS", True, "up", 8, 2),
    (59, "raise_l_cornerlip_o", "MNS", True, "up", 8, 2),
    (60, "raise_r_cornerlip_o", "MNS", True, "up", 8, 2),
    (61, "stretch_l_nose", "ENS", True, "left", 9, 1),
    (62, "stretch_r_nose", "ENS", True, "right", 9, 1),
    (63, "raise_nose", "ENS", True, "up", 9, 1),
    (64, "bend_nose", "ENS", True, "right", 9, 1),
    (65, "raise_l_ear", "ENS", True, "up", 10, 1),
    (66, "raise_r_ear", "ENS", True, "up", 10, 1),
    (67, "pull_l_ear", "ENS", True, "left", 10, 1),
    (68, "pull_r_ear", "ENS", True, "right", 10, 1),
]

FAPS: tuple[Fap, ...] = tuple(Fap(*row) for row in _TABLE)
BY_NAME = {fap.name: fap for fap in FAPS}
GROUP_LABELS = ("visemes and expressions", "jaw, chin, inner lips, lip corners", "eyes: eyelids, eyeballs, pupils",
                "eyebrows", "cheeks", "tongue", "head rotation", "outer lips", "nose", "ears")
# FAP ids of each group in coding order (ascending id within a group)
GROUP_MEMBERS: tuple[tuple[int, ...], ...] = tuple(
    tuple(f.id for f in FAPS if f.group == g) for g in range(1, N_GROUPS + 1))
LOW_LEVEL = tuple(range(3, N_FAPS + 1))        # ids signcast codes (1 and 2 are high-level FAPs)
HEAD_ROTATION = (48, 49, 50)
# Largest value a FAP may take, FAP units: the 5-bit range field times 60 (mpeg4-facts.md §1.7)
# times the step, as for BAPs; far beyond any face (3.6 MNS of jaw opening at step 2).
MAX_LEVEL = 31 * 60


def fap(fap_id: int) -> Fap:
    """The FAP with 1-based id `fap_id`."""
    return FAPS[fap_id - 1]


def steps() -> np.ndarray:
    """(68,) int64 quantisation step of every FAP (index = id - 1), FAP units."""
    return np.array([f.step for f in FAPS], dtype=np.int64)


def limits() -> np.ndarray:
    """(68,) int64 largest |value| of every FAP, FAP units (MAX_LEVEL steps)."""
    return steps() * MAX_LEVEL


def saturated(faps: np.ndarray) -> np.ndarray:
    """FAP values (T, 68) int64 clipped to limits(): what a measured face sends when a tracking failure puts a
    FAP beyond its coded range (an eyelid measured 1.85 iris diameters open, say). The FBA encoder itself
    refuses such values; the difference shows in the decoded motion's FAP error."""
    bound = limits()
    return np.clip(np.asarray(faps, dtype=np.int64), -bound, bound)


def _check() -> None:
    assert [f.id for f in FAPS] == list(range(1, N_FAPS + 1)), "FAP ids must be 1..68 in order"
    assert sorted(i for g in GROUP_MEMBERS for i in g) == list(range(1, N_FAPS + 1))
    assert [len(g) for g in GROUP_MEMBERS] == [2, 16, 12, 8, 4, 5, 3, 10, 4, 4]


_check()
