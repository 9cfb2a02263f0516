"""The compiled Motion -> BAP split (kernels/lab_rotations.anatomical_euler) against the NumPy/scipy path
it replaced: F^-1 (N^-1 q) F, then media.rotations.to_euler (scipy's from_quat and as_euler). The BAP
integers are rounded angles, so the angles must be bitwise equal, not merely close: checked on real
retargeted letters and on poses at the awkward places of the Euler split (angles near +-pi, the
abduction at +-pi/2 where the split is in gimbal lock, and just off it)."""
from __future__ import annotations

import functools

import numpy as np
import pytest

from comparisons import bap_table
from comparisons.fba_mapping import (
    EULER_ORDER,
    _bone_rotations,
    _bone_sources,
    avatar_bap_map,
    motion_to_baps,
)
from kernels import lab_rotations
from media import rotations
from media.fingerspelling import letter_motion
from media.motion import Motion


def scipy_baps(motion: Motion) -> np.ndarray:
    """motion_to_baps as it was before the compiled split (strict check left out)."""
    bap_map = avatar_bap_map()
    frames, neutrals, columns, signs = bap_map.arrays
    anatomical = lab_rotations.anatomical_rotations(_bone_rotations(motion, bap_map), frames, neutrals)
    angles = rotations.to_euler(anatomical, EULER_ORDER) * signs
    values = np.zeros((motion.n_frames, bap_table.N_BAPS), dtype=np.int64)
    values[:, columns] = np.round(angles / bap_table.ROTATION_UNIT_RAD).astype(np.int64)
    translation_mm = np.round(motion.root_translation / bap_table.TRANSLATION_UNIT_M).astype(np.int64)
    values[:, [180, 181, 182]] = translation_mm[:, [1, 0, 2]]
    return values


def scipy_angles(motion: Motion) -> np.ndarray:
    frames, neutrals, _, _ = avatar_bap_map().arrays
    anatomical = lab_rotations.anatomical_rotations(_bone_rotations(motion, avatar_bap_map()), frames, neutrals)
    return rotations.to_euler(anatomical, EULER_ORDER)


def compiled_angles(motion: Motion) -> np.ndarray:
    bap_map = avatar_bap_map()
    frames, neutrals, _, _ = bap_map.arrays
    mapped, source = _bone_sources(motion.bone_names, bap_map.bone_names)
    return lab_rotations.anatomical_euler(motion.rotations, mapped, source, frames, neutrals)


@functools.lru_cache(maxsize=8)
def _letter(letter: str) -> Motion:
    return letter_motion("ase", letter, 25.0)


@pytest.mark.parametrize("letter", ["A", "H", "J", "Z"])
def test_letters_bitwise(letter):
    motion = _letter(letter)
    assert np.array_equal(compiled_angles(motion).view(np.int64), scipy_angles(motion).view(np.int64))
    assert np.array_equal(motion_to_baps(motion), scipy_baps(motion))


def _posed(anatomical: np.ndarray) -> Motion:
    """A motion of every mapped bone whose anatomical rotations F^-1 (N^-1 q) F are `anatomical` (T, B, 4)."""
    bap_map = avatar_bap_map()
    frames, neutrals, _, _ = bap_map.arrays
    conj = np.array([1.0, -1.0, -1.0, -1.0])
    q = rotations.multiply(neutrals, rotations.multiply(frames, rotations.multiply(anatomical, frames * conj)))
    return Motion(25.0, bap_map.bone_names, q, np.zeros((len(q), 3)))


def _edge_anatomical(n_bones: int) -> np.ndarray:
    """(T, B, 4) anatomical rotations at the Euler split's edges, from its own from_euler."""
    rng = np.random.default_rng(7)
    pi, half = np.pi, np.pi / 2
    rows = []
    for f in (pi, -pi, pi - 1e-9, -pi + 1e-9, 0.0, 3.14159, -3.14159, 1.0):
        for a in (half, -half, half - 1e-8, -half + 1e-8, half - 1e-6, 0.0, 0.3):
            for t in (pi, -pi, pi - 1e-9, 0.0, -2.5):
                rows.append((f, a, t))
    angles = np.array(rows)
    n = -(-len(angles) // n_bones) * n_bones
    angles = np.concatenate([angles, rng.uniform(-pi, pi, (n - len(angles), 3)) * [1, 0.5, 1]])
    q = rotations.from_euler(angles.reshape(-1, n_bones, 3), EULER_ORDER)
    q[::3] *= -1.0                                   # both signs of each quaternion
    return q * rng.uniform(0.999, 1.001, q.shape[:-1] + (1,))     # not quite unit: the normalisation counts


def test_edges_bitwise():
    bap_map = avatar_bap_map()
    motion = _posed(_edge_anatomical(len(bap_map.bones)))
    assert np.array_equal(compiled_angles(motion).view(np.int64), scipy_angles(motion).view(np.int64))
    assert np.array_equal(motion_to_baps(motion), scipy_baps(motion))


def test_edges_reach_gimbal_lock_and_pi():
    """The edge poses do exercise the special branches (else the bitwise test above proves little)."""
    angles = scipy_angles(_posed(_edge_anatomical(len(avatar_bap_map().bones))))
    assert np.any(angles[..., 2] == 0.0) and np.any(np.abs(np.abs(angles[..., 1]) - np.pi / 2) < 1e-6)
    assert np.any(np.abs(np.abs(angles[..., 0]) - np.pi) < 1e-6)


def test_missing_bones_at_rest():
    """Bones a motion lacks are at the rig's rest (identity) in both paths."""
    full = _letter("A")
    keep = [k for k, name in enumerate(full.bone_names) if not name.startswith(("finger", "wrist"))]
    motion = Motion(full.fps, tuple(full.bone_names[k] for k in keep), full.rotations[:, keep],
                    full.root_translation)
    assert np.array_equal(motion_to_baps(motion), scipy_baps(motion))
