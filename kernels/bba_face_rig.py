"""Numba-compiled damped Gauss-Newton solve of the face rig's carried bones (media/face_rig.py `_carry`).

media/face_rig.py documents the rig: carrier bones below an anchor turn so that the heads of the skinned
bones they carry move by given displacements. This kernel is that solve, frame by frame: per frame and
iteration it poses the carriers (parents first), linearises the skinned heads' motion in the carriers'
turns (a 3 x 3 block -[head - pivot]x per carrier on the bone's chain), takes the smallest turns meeting
the linearised targets with damping (J^T (J J^T + d^2 I)^-1 r), caps the largest turn at max_turn and
applies the turns about the carriers' posed heads. J is mostly zero: the blocks of J J^T are summed over
the shared carriers only, and skinned bones that share no carrier (the two corners, the cheeks, the
brows, the nose, the upper lip) are solved as separate small systems. The result equals the dense
NumPy reference (media/face_rig.py `_carry_numpy`) to rounding (~1e-14).

All geometry is in the anchor's rest frame, metres. Compiled nopython with cache=True; imports nothing
of signcast.
"""
import numpy as np
from numba import njit


@njit(cache=True)
def _matvec(m, v, out):
    for r in range(3):
        out[r] = m[r, 0] * v[0] + m[r, 1] * v[1] + m[r, 2] * v[2]


@njit(cache=True)
def _matmul(a, b, out):
    for r in range(3):
        for c in range(3):
            out[r, c] = a[r, 0] * b[0, c] + a[r, 1] * b[1, c] + a[r, 2] * b[2, c]


@njit(cache=True)
def _pose(local, carrier_heads, carrier_parents, rotation, offset):
    """World (anchor-relative) rotation (C, 3, 3) and offset (C, 3) of each carrier from its local turn."""
    point = np.empty(3)
    moved = np.empty(3)
    for j in range(len(carrier_parents)):
        p = carrier_parents[j]
        head = carrier_heads[j]
        if p < 0:
            rotation[j] = local[j]
            _matvec(local[j], head, moved)
            for r in range(3):
                offset[j, r] = head[r] - moved[r]
        else:
            _matmul(rotation[p], local[j], rotation[j])
            _matvec(rotation[p], head, point)
            _matvec(rotation[j], head, moved)
            for r in range(3):
                offset[j, r] = offset[p, r] + point[r] - moved[r]


@njit(cache=True)
def _solve_spd(matrix, rhs, n):
    """Solve matrix[:n, :n] x = rhs[:n] in place (x in rhs) for a symmetric positive definite matrix:
    Cholesky, matrix's lower triangle overwritten by the factor."""
    for j in range(n):
        total = matrix[j, j]
        for k in range(j):
            total -= matrix[j, k] * matrix[j, k]
        root = np.sqrt(total)
        matrix[j, j] = root
        for i in range(j + 1, n):
            total = matrix[i, j]
            for k in range(j):
                total -= matrix[i, k] * matrix[j, k]
            matrix[i, j] = total / root
    for i in range(n):
        total = rhs[i]
        for k in range(i):
            total -= matrix[i, k] * rhs[k]
        rhs[i] = total / matrix[i, i]
    for i in range(n - 1, -1, -1):
        total = rhs[i]
        for k in range(i + 1, n):
            total -= matrix[k, i] * rhs[k]
        rhs[i] = total / matrix[i, i]


@njit(cache=True)
def carry(wanted, carrier_heads, carrier_parents, skinned_heads, skinned_parents, on_chain, group_members,
          group_start, iterations, damping, max_turn):
    """Local turns of the carriers and the posed rotation of each skinned bone's parent.

    wanted: (T, S, 3) float64 head displacement of each skinned bone. carrier_heads: (C, 3) rest heads of
    the carriers, parents before children; carrier_parents: (C,) int64 index of each carrier's parent
    among the carriers, -1 for the anchor. skinned_heads: (S, 3) rest heads of the skinned bones;
    skinned_parents: (S,) int64 their parents among the carriers (-1: the anchor). on_chain: (S, C) bool,
    carrier j carries skinned bone i. group_members (S,) int64, group_start (G + 1,) int64: the skinned
    bones grouped by shared carriers (group g: group_members[group_start[g]:group_start[g + 1]]); bones
    of different groups share no carrier, so J J^T is block diagonal and each group's block is solved
    alone (Cholesky: the block is symmetric positive definite). Returns local (T, C, 3, 3) rotation matrices and parent (T, S, 3, 3)
    the final posed rotation of each skinned bone's parent (identity for the anchor).
    """
    n_frames, n_skinned = wanted.shape[0], wanted.shape[1]
    n_carriers = carrier_heads.shape[0]
    local = np.zeros((n_frames, n_carriers, 3, 3))
    parent_out = np.zeros((n_frames, n_skinned, 3, 3))
    rotation = np.empty((n_carriers, 3, 3))
    offset = np.empty((n_carriers, 3))
    heads = np.empty((n_skinned, 3))
    pivots = np.empty((n_carriers, 3))
    blocks = np.zeros((n_skinned, n_carriers, 3, 3))       # J's blocks: -[head_i - pivot_j]x
    normal = np.empty((3 * n_skinned, 3 * n_skinned))
    residual = np.empty(3 * n_skinned)
    rhs = np.empty(3 * n_skinned)
    solved = np.empty(3 * n_skinned)
    step = np.empty((n_carriers, 3))
    turn = np.empty((3, 3))
    cross = np.empty((3, 3))
    scratch = np.empty((3, 3))
    scratch2 = np.empty((3, 3))
    arm = np.empty(3)
    for t in range(n_frames):
        current = local[t]
        for j in range(n_carriers):
            for r in range(3):
                current[j, r, r] = 1.0
        for _ in range(iterations):
            _pose(current, carrier_heads, carrier_parents, rotation, offset)
            for i in range(n_skinned):
                p = skinned_parents[i]
                if p < 0:
                    for r in range(3):
                        heads[i, r] = skinned_heads[i, r]
                else:
                    _matvec(rotation[p], skinned_heads[i], arm)
                    for r in range(3):
                        heads[i, r] = arm[r] + offset[p, r]
                for r in range(3):
                    residual[3 * i + r] = wanted[t, i, r] - (heads[i, r] - skinned_heads[i, r])
            for j in range(n_carriers):
                _matvec(rotation[j], carrier_heads[j], arm)
                for r in range(3):
                    pivots[j, r] = arm[r] + offset[j, r]
            for i in range(n_skinned):
                for j in range(n_carriers):
                    if on_chain[i, j]:
                        x = heads[i, 0] - pivots[j, 0]
                        y = heads[i, 1] - pivots[j, 1]
                        z = heads[i, 2] - pivots[j, 2]
                        b = blocks[i, j]
                        b[0, 0], b[0, 1], b[0, 2] = 0.0, z, -y
                        b[1, 0], b[1, 1], b[1, 2] = -z, 0.0, x
                        b[2, 0], b[2, 1], b[2, 2] = y, -x, 0.0
            # normal = J J^T + damping^2 I, block (i, k) = sum_j B_ij B_kj^T over the carriers both share
            for g in range(len(group_start) - 1):
                members = group_members[group_start[g]:group_start[g + 1]]
                m = len(members)
                for a in range(m):
                    i = members[a]
                    for b in range(a, m):
                        k = members[b]
                        for r in range(3):
                            for c in range(3):
                                total = 0.0
                                for j in range(n_carriers):
                                    if on_chain[i, j] and on_chain[k, j]:
                                        total += (blocks[i, j, r, 0] * blocks[k, j, c, 0] + blocks[i, j, r, 1] * blocks[k, j, c, 1]
                                                  + blocks[i, j, r, 2] * blocks[k, j, c, 2])
                                normal[3 * a + r, 3 * b + c] = total
                                normal[3 * b + c, 3 * a + r] = total
                    for r in range(3):
                        normal[3 * a + r, 3 * a + r] += damping * damping
                        rhs[3 * a + r] = residual[3 * i + r]
                _solve_spd(normal, rhs, 3 * m)
                for a in range(m):
                    for r in range(3):
                        solved[3 * members[a] + r] = rhs[3 * a + r]
            largest = 0.0
            for j in range(n_carriers):
                for c in range(3):
                    total = 0.0
                    for i in range(n_skinned):
                        if on_chain[i, j]:
                            for r in range(3):
                                total += blocks[i, j, r, c] * solved[3 * i + r]
                    step[j, c] = total
                size = np.sqrt(step[j, 0] ** 2 + step[j, 1] ** 2 + step[j, 2] ** 2)
                largest = max(largest, size)
            scale = min(1.0, max_turn / max(largest, 1e-300))
            for j in range(n_carriers):
                # Rodrigues: I + sin(a) K + (1 - cos(a)) K K, K the cross matrix of the unit axis
                vx, vy, vz = step[j, 0] * scale, step[j, 1] * scale, step[j, 2] * scale
                angle = np.sqrt(vx * vx + vy * vy + vz * vz)
                unit = max(angle, 1e-300)
                ux, uy, uz = vx / unit, vy / unit, vz / unit
                cross[0, 0], cross[0, 1], cross[0, 2] = 0.0, -uz, uy
                cross[1, 0], cross[1, 1], cross[1, 2] = uz, 0.0, -ux
                cross[2, 0], cross[2, 1], cross[2, 2] = -uy, ux, 0.0
                _matmul(cross, cross, scratch)
                sine, versine = np.sin(angle), 1.0 - np.cos(angle)
                for r in range(3):
                    for c in range(3):
                        turn[r, c] = (1.0 if r == c else 0.0) + sine * cross[r, c] + versine * scratch[r, c]
                # local = parent^T turn parent local, parent: the carrier's parent posed at this iteration's start
                p = carrier_parents[j]
                if p < 0:
                    _matmul(turn, current[j], scratch)
                    current[j] = scratch
                else:
                    _matmul(rotation[p].T, turn, scratch)
                    _matmul(scratch, rotation[p], scratch2)
                    _matmul(scratch2, current[j], scratch)
                    current[j] = scratch
        _pose(current, carrier_heads, carrier_parents, rotation, offset)
        for i in range(n_skinned):
            p = skinned_parents[i]
            if p < 0:
                for r in range(3):
                    parent_out[t, i, r, r] = 1.0
            else:
                parent_out[t, i] = rotation[p]
    return local, parent_out
