"""Numba-compiled damped Gauss-Newton solve of the face rig's carried bones (media/face_rig.py `_carry`).

media/face_rig.py documents the rig: carrier bones below an anchor turn so that the heads of the skinned
bones they carry move by given displacements. This kernel is that solve, frame by frame: per frame and
iteration it poses the carriers (parents first), linearises the skinned heads' motion in the carriers'
turns (a 3 x 3 block -[head - pivot]x per carrier on the bone's chain), takes the smallest turns meeting
the linearised targets with damping (J^T (J J^T + d^2 I)^-1 r), caps the largest turn at max_turn and
applies the turns about the carriers' posed heads. J is mostly zero: the blocks of J J^T are summed over
the shared carriers only, and skinned bones that share no carrier (the two corners, the cheeks, the
brows, the nose, the upper lip) are solved as separate small systems; a bone alone in its group has
its 3 x 3 system built and solved in one loop (`_solve_alone`). The result equals the dense
NumPy reference (media/face_rig.py `_carry_numpy`) to rounding (~1e-14).

`carry` takes the frames together: each step runs as a loop over frames that the compiler vectorises (about
2x frame by frame). error_model="numpy" only drops the ZeroDivisionError checks, whose divisors are never zero
(a Cholesky pivot of a positive definite matrix, lengths floored at 1e-300). The solve's result is the dense
NumPy reference's to within 1e-12 (tests/test_face_rig_speed.py); nothing here reproduces another library's
rounding.

J's blocks -[lever]x and Rodrigues' K are cross matrices with a zero diagonal: `carry` leaves out the
products with those zeros in J J^T, J^T x and K K. The frame loops index the state arrays whole rather than
through views (a view costs reference counting) and avoid slice assignments.

`from_matrix` and `bone_turns` are the conversions that follow the solve (media/rotations.py from_matrix, and
between then to_matrix), compiled; tests/test_face_rig_speed.py checks them against scipy / NumPy within 1e-12
per component.

`carry_into` is what media/face_rig.py calls per anchor and clip: the held frames (`held_runs`), the solve
with the rig's index tables made once (`carry_tables`), the carriers' and the skinned bones' quaternions written
into the caller's array (`quaternions_into`, `bone_turns`), in one call.

`_solve_rows`, `_solve_frames` and `_iterate` are inlined into their callers (inline="always"): Numba optimises a
callee's code again inside each caller's module, so nested, the solve's large body went through LLVM four times (the
first with_face_bones of a fresh environment compiled in 42 s; inlined, 24 s; the machine code runs as fast).

All geometry is in the anchor's rest frame, metres. Compiled nopython with cache=True; imports nothing
of signcast.
"""
import numpy as np
from numba import njit

# Below this many frames (measured on the head rig: about where the two cross) the carriers' posing and turning
# run as one loop per carrier with each frame's matrices in registers (`_pose_child`, `_turn_carrier`; not
# vectorised): there the vectorised form's nine loops per matrix product cost more than their vectors save. Both
# forms are the same operations in the same order (tests/test_face_rig_speed.py runs both).
FEW_FRAMES = 40


@njit(cache=True)
def _rows_of(mask):
    """The True columns of each row of a (R, C) bool array in CSR form: (start (R + 1,), index (R * C,)) int64,
    row r's columns ascending in index[start[r]:start[r + 1]]."""
    n_rows, n_columns = mask.shape
    start = np.zeros(n_rows + 1, np.int64)
    index = np.empty(n_rows * n_columns, np.int64)
    n = 0
    for r in range(n_rows):
        for c in range(n_columns):
            if mask[r, c]:
                index[n] = c
                n += 1
        start[r + 1] = n
    return start, index


@njit(cache=True)
def _layout(on_chain, group_members, group_start):
    """Index lists of the sparse J, made once per call: per skinned bone its carriers (chain_start /
    chain_index, carriers ascending), per carrier its skinned bones (carried_start / carried_index, skinned
    ascending), and per pair (a <= b) of bones in a group the carriers both share (pair_start / pair_index,
    ascending; pairs in the order the solve visits them)."""
    n_carriers = on_chain.shape[1]
    chain_start, chain_index = _rows_of(on_chain)
    carried_start, carried_index = _rows_of(on_chain.T)
    n_pairs = 0
    for g in range(len(group_start) - 1):
        m = group_start[g + 1] - group_start[g]
        n_pairs += m * (m + 1) // 2
    pair_start = np.zeros(n_pairs + 1, np.int64)
    pair_index = np.empty(n_pairs * n_carriers, np.int64)
    n = 0
    pair = 0
    for g in range(len(group_start) - 1):
        first, last = group_start[g], group_start[g + 1]
        for a in range(first, last):
            i = group_members[a]
            for b in range(a, last):
                k = group_members[b]
                for j in range(n_carriers):
                    if on_chain[i, j] and on_chain[k, j]:
                        pair_index[n] = j
                        n += 1
                pair += 1
                pair_start[pair] = n
    return chain_start, chain_index, carried_start, carried_index, pair_start, pair_index


@njit(cache=True)
def from_matrix(matrix):
    """Rotation matrices (N, 3, 3), orthogonal to rounding (the solve's products) -> (N, 4) float64 (w, x, y, z) unit
    quaternions with w >= 0: the largest of the trace and the diagonal picks the formula (Shepperd 1978), then the
    quaternion is normalised."""
    n = matrix.shape[0]
    out = np.empty((n, 4))
    for k in range(n):
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = _quaternion(
            matrix[k, 0, 0], matrix[k, 0, 1], matrix[k, 0, 2], matrix[k, 1, 0], matrix[k, 1, 1], matrix[k, 1, 2],
            matrix[k, 2, 0], matrix[k, 2, 1], matrix[k, 2, 2])
    return out


@njit(cache=True)
def transposed_products(parent, turned):
    """parent^T turned of each (T, K, 3, 3) pair, (T, K, 3, 3)."""
    out = np.empty(parent.shape)
    for t in range(parent.shape[0]):
        for k in range(parent.shape[1]):
            for r in range(3):
                for c in range(3):
                    out[t, k, r, c] = (parent[t, k, 0, r] * turned[t, k, 0, c] + parent[t, k, 1, r] * turned[t, k, 1, c]
                                       + parent[t, k, 2, r] * turned[t, k, 2, c])
    return out


@njit(cache=True)
def quaternions_into(matrices, out, column):
    """`from_matrix` of matrices (T, K, 3, 3) written to out[:, column:column + K] ((T, F, 4) float64, w, x, y, z)."""
    for t in range(matrices.shape[0]):
        for k in range(matrices.shape[1]):
            out[t, column + k, 0], out[t, column + k, 1], out[t, column + k, 2], out[t, column + k, 3] = _quaternion(
                matrices[t, k, 0, 0], matrices[t, k, 0, 1], matrices[t, k, 0, 2], matrices[t, k, 1, 0], matrices[t, k, 1, 1],
                matrices[t, k, 1, 2], matrices[t, k, 2, 0], matrices[t, k, 2, 1], matrices[t, k, 2, 2])


@njit(cache=True)
def _quaternion(m00, m01, m02, m10, m11, m12, m20, m21, m22):
    """`from_matrix` of one matrix, its entries m[r, c] given as mrc (scalars: a view of each matrix would cost
    reference counting): (w, x, y, z)."""
    trace = m00 + m11 + m22
    if trace >= m00 and trace >= m11 and trace >= m22:
        w, x, y, z = 1.0 + trace, m21 - m12, m02 - m20, m10 - m01
    elif m00 >= m11 and m00 >= m22:
        w, x, y, z = m21 - m12, 1.0 - trace + 2.0 * m00, m10 + m01, m20 + m02
    elif m11 >= m22:
        w, x, y, z = m02 - m20, m01 + m10, 1.0 - trace + 2.0 * m11, m21 + m12
    else:
        w, x, y, z = m10 - m01, m02 + m20, m12 + m21, 1.0 - trace + 2.0 * m22
    norm = np.sqrt(w * w + x * x + y * y + z * z)
    if w < 0.0:
        norm = -norm
    return w / norm, x / norm, y / norm, z / norm


@njit(cache=True)
def held_runs(head_moved):
    """Frames whose targets equal the previous frame's bit for bit (a held face) have the same solution:
    head_moved (T, S, 3) float64 -> (run (T,) int64 each frame's index among the distinct frames, first (U,)
    int64 the frame each distinct one starts at)."""
    bits = head_moved.view(np.int64)
    n_frames = bits.shape[0]
    run = np.empty(n_frames, np.int64)
    first = np.empty(n_frames, np.int64)
    u = -1
    for t in range(n_frames):
        changed = t == 0
        if not changed:
            for i in range(bits.shape[1]):
                for r in range(3):
                    if bits[t, i, r] != bits[t - 1, i, r]:
                        changed = True
        if changed:
            u += 1
            first[u] = t
        run[t] = u
    return run, first[:u + 1].copy()


@njit(cache=True)
def carry_into(head_moved, tail_moved, carrier_heads, carrier_parents, skinned_heads, skinned_parents, group_members,
               group_start, chain_start, chain_index, carried_start, carried_index, pair_start, pair_index, entry, arms,
               iterations, damping, max_turn, tolerance, out, column):
    """The face rig's carry of one anchor in one call: `carry` of the distinct frames (`held_runs`; the rig's
    tables from `carry_tables`), the carriers' local turns as quaternions (`from_matrix`) written to
    out[:, column:column + C] ((T, F, 4)), then the skinned bones' rotations parent^T turned (`bone_turns`,
    `transposed_products`) as quaternions to out[:, column + C:column + C + S].

    head_moved, tail_moved (T, S, 3) metres; arms (S, 3). Returns nothing (what it makes is in out).
    """
    run, first = held_runs(head_moved)
    local, parent = _solve_rows(head_moved, first, run, carrier_heads, carrier_parents, skinned_heads,
                                skinned_parents, group_members, group_start, chain_start, chain_index, carried_start,
                                carried_index, pair_start, pair_index, entry, iterations, damping, max_turn, tolerance)
    quaternions_into(local, out, column)
    quaternions_into(transposed_products(parent, bone_turns(arms, head_moved, tail_moved)), out,
                     column + carrier_heads.shape[0])


@njit(cache=True, error_model="numpy")
def carry(wanted, carrier_heads, carrier_parents, skinned_heads, skinned_parents, on_chain, group_members,
          group_start, iterations, damping, max_turn, tolerance=0.0):
    """Local turns of the carriers and the posed rotation of each skinned bone's parent.

    wanted: (T, S, 3) float64 head displacement of each skinned bone. carrier_heads: (C, 3) rest heads of
    the carriers, parents before children; carrier_parents: (C,) int64 index of each carrier's parent
    among the carriers, -1 for the anchor. skinned_heads: (S, 3) rest heads of the skinned bones;
    skinned_parents: (S,) int64 their parents among the carriers (-1: the anchor). on_chain: (S, C) bool,
    carrier j carries skinned bone i. group_members (S,) int64, group_start (G + 1,) int64: the skinned
    bones grouped by shared carriers (group g: group_members[group_start[g]:group_start[g + 1]]); bones
    of different groups share no carrier, so J J^T is block diagonal and each group's block is solved
    alone (Cholesky: the block is symmetric positive definite). Returns local (T, C, 3, 3) rotation
    matrices and parent (T, S, 3, 3) the final posed rotation of each skinned bone's parent (identity for
    the anchor).

    Every frame is solved alone, by the same operations in the same order whatever its values, so the frames go
    through each operation together: state arrays keep the frame last and every step is a loop over frames,
    which the compiler turns into vector instructions (the turns' sin and 1 - cos as Taylor series,
    `_sine_versine`). tolerance (radians): a frame stops after the iteration whose largest carrier turn is below it
    (`_solve_frames`); 0 runs every frame `iterations` times.
    """
    chain_start, chain_index, carried_start, carried_index, pair_start, pair_index, entry = carry_tables(
        on_chain, group_members, group_start)
    frames = np.arange(wanted.shape[0])
    return _solve_rows(wanted, frames, frames, carrier_heads, carrier_parents, skinned_heads, skinned_parents,
                       group_members, group_start, chain_start, chain_index, carried_start, carried_index, pair_start,
                       pair_index, entry, iterations, damping, max_turn, tolerance)


@njit(cache=True, error_model="numpy", inline="always")
def _solve_rows(wanted, rows, source, carrier_heads, carrier_parents, skinned_heads, skinned_parents, group_members,
                group_start, chain_start, chain_index, carried_start, carried_index, pair_start, pair_index, entry,
                iterations, damping, max_turn, tolerance):
    """Solves the frames `rows` (R,) int64 of wanted (T, S, 3) together (_solve_frames) and returns (local
    (T, C, 3, 3), parent (T, S, 3, 3)) of every frame t from the solved frame source[t] (T,) int64 (an index
    into rows)."""
    n_frames, n_skinned, n_carriers = wanted.shape[0], wanted.shape[1], carrier_heads.shape[0]
    target = np.empty((n_skinned, 3, len(rows)))
    for u in range(len(rows)):
        for i in range(n_skinned):
            for r in range(3):
                target[i, r, u] = wanted[rows[u], i, r]
    current, rotation = _solve_frames(target, carrier_heads, carrier_parents, skinned_heads, skinned_parents,
                                      group_members, group_start, chain_start, chain_index, carried_start,
                                      carried_index, pair_start, pair_index, entry, iterations, damping, max_turn,
                                      tolerance)
    local = np.empty((n_frames, n_carriers, 3, 3))
    parent = np.zeros((n_frames, n_skinned, 3, 3))
    for t in range(n_frames):
        _frame_out(current, rotation, skinned_parents, source[t], t, local, parent)
    return local, parent


@njit(cache=True)
def carry_tables(on_chain, group_members, group_start):
    """The index tables of `carry`'s sparse J, which depend on the rig only (a caller carrying many clips
    makes them once): `_layout`'s six lists, then entry (S, C) int64, (skinned i, carrier j) -> the row of
    their block in chain_index's order (-1: j does not carry i)."""
    chain_start, chain_index, carried_start, carried_index, pair_start, pair_index = _layout(
        on_chain, group_members, group_start)
    n_skinned, n_carriers = on_chain.shape
    entry = np.full((n_skinned, n_carriers), -1, np.int64)
    for i in range(n_skinned):
        for n in range(chain_start[i], chain_start[i + 1]):
            entry[i, chain_index[n]] = n
    return chain_start, chain_index, carried_start, carried_index, pair_start, pair_index, entry


@njit(cache=True)
def _frame_out(current, rotation, skinned_parents, u, t, local, parent_out):
    """Frame t of `carry`'s results from solved frame u of the state: local[t] (C, 3, 3) the carriers' turns,
    parent_out[t] (S, 3, 3) each skinned bone's posed parent (identity for the anchor; parent_out is zeroed)."""
    for j in range(current.shape[0]):
        for r in range(3):
            for c in range(3):
                local[t, j, r, c] = current[j, r, c, u]
    for i in range(len(skinned_parents)):
        p = skinned_parents[i]
        for r in range(3):
            if p < 0:
                parent_out[t, i, r, r] = 1.0
            else:
                for c in range(3):
                    parent_out[t, i, r, c] = rotation[p, r, c, u]


@njit(cache=True, error_model="numpy", inline="always")
def _solve_frames(target, carrier_heads, carrier_parents, skinned_heads, skinned_parents, group_members, group_start,
                  chain_start, chain_index, carried_start, carried_index, pair_start, pair_index, entry, iterations,
                  damping, max_turn, tolerance):
    """`carry`'s solve with the frame last: target (S, 3, T) head displacements and the rig's tables
    (`carry_tables`) -> current (C, 3, 3, T) the carriers' local turns and rotation (C, 3, 3, T) their final
    posed rotations.

    Per-frame stopping: a frame whose largest carrier turn in an iteration is below `tolerance` (radians) is
    done after that iteration, and the iterations go on with the frames left (the state arrays compacted to
    them; each frame's arithmetic is its own, so which frames share a batch changes no result). At most
    `iterations` iterations; tolerance 0 runs them all for every frame."""
    n_skinned, T = target.shape[0], target.shape[2]
    n_carriers = carrier_heads.shape[0]
    current = np.zeros((n_carriers, 3, 3, T))
    for j in range(n_carriers):
        for r in range(3):
            current[j, r, r, :] = 1.0
    result = current
    if T > 0:
        result = np.empty((n_carriers, 3, 3, T))
        active = np.arange(T)
        left = iterations
        while left > 0:
            ran, largest = _iterate(current, target, carrier_heads, carrier_parents, skinned_heads, skinned_parents,
                                    group_members, group_start, chain_start, chain_index, carried_start, carried_index,
                                    pair_start, pair_index, entry, left, damping, max_turn, tolerance)
            left -= ran
            n_keep = 0
            for u in range(len(active)):
                if left > 0 and largest[u] >= tolerance:
                    n_keep += 1
                else:
                    for j in range(n_carriers):
                        for r in range(3):
                            for c in range(3):
                                result[j, r, c, active[u]] = current[j, r, c, u]
            if n_keep == 0:
                break
            if n_keep < len(active):
                kept = np.empty(n_keep, np.int64)
                kept_current = np.empty((n_carriers, 3, 3, n_keep))
                kept_target = np.empty((n_skinned, 3, n_keep))
                v = 0
                for u in range(len(active)):
                    if largest[u] >= tolerance:
                        kept[v] = active[u]
                        for j in range(n_carriers):
                            for r in range(3):
                                for c in range(3):
                                    kept_current[j, r, c, v] = current[j, r, c, u]
                        for i in range(n_skinned):
                            for r in range(3):
                                kept_target[i, r, v] = target[i, r, u]
                        v += 1
                active, current, target = kept, kept_current, kept_target
    rotation = np.empty((n_carriers, 3, 3, T))
    offset = np.empty((n_carriers, 3, T))
    _pose_frames(result, carrier_heads, carrier_parents, rotation, offset)
    return result, rotation


@njit(cache=True, error_model="numpy", inline="always")
def _iterate(current, target, carrier_heads, carrier_parents, skinned_heads, skinned_parents, group_members,
             group_start, chain_start, chain_index, carried_start, carried_index, pair_start, pair_index, entry,
             iterations, damping, max_turn, tolerance):
    """Up to `iterations` damped Gauss-Newton iterations of the frames of current (C, 3, 3, T), in place, against
    target (S, 3, T); with tolerance > 0 it returns after the first iteration in which some frame's largest
    carrier turn is below tolerance. Returns (the iterations run, largest (T,) each frame's largest carrier turn
    in the last one, before the max_turn cap)."""
    n_skinned, T = target.shape[0], target.shape[2]
    n_carriers = carrier_heads.shape[0]
    rotation = np.empty((n_carriers, 3, 3, T))
    offset = np.empty((n_carriers, 3, T))
    heads = np.empty((n_skinned, 3, T))
    pivots = np.empty((n_carriers, 3, T))
    lever = np.empty((max(chain_start[n_skinned], 1), 3, T))     # head_i - pivot_j: J's block is -[lever]x
    normal = np.empty((3 * n_skinned, 3 * n_skinned, T))
    residual = np.empty((3 * n_skinned, T))
    rhs = np.empty((3 * n_skinned, T))
    solved = np.empty((3 * n_skinned, T))
    step = np.empty((n_carriers, 3, T))
    largest = np.empty(T)
    scale = np.empty(T)
    sine = np.empty(T)
    versine = np.empty(T)
    axis = np.empty((3, T))
    total = np.empty(T)
    totals = np.empty((9, T))
    turn = np.empty((1, 3, 3, T))        # (1, ...): indexed as the (C, 3, 3, T) state arrays are
    left = np.empty((1, 3, 3, T))
    middle = np.empty((1, 3, 3, T))
    product = np.empty((1, 3, 3, T))
    damping2 = damping * damping
    ran = 0
    for _ in range(iterations):
        ran += 1
        _pose_frames(current, carrier_heads, carrier_parents, rotation, offset)
        for i in range(n_skinned):
            p = skinned_parents[i]
            h0, h1, h2 = skinned_heads[i, 0], skinned_heads[i, 1], skinned_heads[i, 2]
            for r in range(3):
                hr = skinned_heads[i, r]
                if p < 0:
                    for t in range(T):
                        heads[i, r, t] = hr
                else:
                    for t in range(T):
                        arm = rotation[p, r, 0, t] * h0 + rotation[p, r, 1, t] * h1 + rotation[p, r, 2, t] * h2
                        heads[i, r, t] = arm + offset[p, r, t]
                for t in range(T):
                    residual[3 * i + r, t] = target[i, r, t] - (heads[i, r, t] - hr)
        for j in range(n_carriers):
            h0, h1, h2 = carrier_heads[j, 0], carrier_heads[j, 1], carrier_heads[j, 2]
            for r in range(3):
                for t in range(T):
                    arm = rotation[j, r, 0, t] * h0 + rotation[j, r, 1, t] * h1 + rotation[j, r, 2, t] * h2
                    pivots[j, r, t] = arm + offset[j, r, t]
        for i in range(n_skinned):
            for n in range(chain_start[i], chain_start[i + 1]):
                j = chain_index[n]
                for r in range(3):
                    for t in range(T):
                        lever[n, r, t] = heads[i, r, t] - pivots[j, r, t]
        # normal = J J^T + damping^2 I, block (i, k) = sum_j B_ij B_kj^T over the carriers both share
        pair = 0
        for g in range(len(group_start) - 1):
            first, last = group_start[g], group_start[g + 1]
            m = last - first
            if m == 1:                  # a bone alone: its 3 x 3 block built and solved in one loop
                i = group_members[first]
                for t in range(T):
                    for e in range(9):
                        totals[e, t] = 0.0
                for n in range(pair_start[pair], pair_start[pair + 1]):
                    j = pair_index[n]
                    _add_block_product(lever, entry[i, j], entry[i, j], totals)
                pair += 1
                _solve_alone(totals, residual, i, damping2, solved)
                continue
            for a in range(m):
                i = group_members[first + a]
                for b_ in range(a, m):
                    k = group_members[first + b_]
                    for e in range(9):
                        for t in range(T):
                            totals[e, t] = 0.0
                    for n in range(pair_start[pair], pair_start[pair + 1]):
                        j = pair_index[n]
                        _add_block_product(lever, entry[i, j], entry[k, j], totals)
                    for r in range(3):
                        for c in range(3):
                            for t in range(T):
                                normal[3 * a + r, 3 * b_ + c, t] = totals[3 * r + c, t]
                                normal[3 * b_ + c, 3 * a + r, t] = totals[3 * r + c, t]
                    pair += 1
                for r in range(3):
                    for t in range(T):
                        normal[3 * a + r, 3 * a + r, t] += damping2
                        rhs[3 * a + r, t] = residual[3 * i + r, t]
            _solve_spd_frames(normal, rhs, 3 * m, total)
            for a in range(m):
                for r in range(3):
                    for t in range(T):
                        solved[3 * group_members[first + a] + r, t] = rhs[3 * a + r, t]
        for t in range(T):
            largest[t] = 0.0
        for j in range(n_carriers):
            for c in range(3):
                for t in range(T):
                    total[t] = 0.0
                # sum_i B_ij^T solved_i over rows r = 0, 1, 2 of column c, without row c (B_ij[c, c] = 0); with
                # (g, h) = (c + 1, c + 2) mod 3, B_ij[g, c] = -lever[h] and B_ij[h, c] = lever[g]
                g, h = (c + 1) % 3, (c + 2) % 3
                for n in range(carried_start[j], carried_start[j + 1]):
                    i = carried_index[n]
                    e = entry[i, j]
                    if g < h:
                        for t in range(T):
                            total[t] -= lever[e, h, t] * solved[3 * i + g, t]
                            total[t] += lever[e, g, t] * solved[3 * i + h, t]
                    else:
                        for t in range(T):
                            total[t] += lever[e, g, t] * solved[3 * i + h, t]
                            total[t] -= lever[e, h, t] * solved[3 * i + g, t]
                for t in range(T):
                    step[j, c, t] = total[t]
            for t in range(T):
                size = np.sqrt(step[j, 0, t] ** 2 + step[j, 1, t] ** 2 + step[j, 2, t] ** 2)
                largest[t] = max(largest[t], size)
        for t in range(T):
            scale[t] = min(1.0, max_turn / max(largest[t], 1e-300))
        for j in range(n_carriers):
            # Rodrigues: I + sin(a) K + (1 - cos(a)) K K, K the cross matrix of the unit axis
            for t in range(T):
                vx, vy, vz = step[j, 0, t] * scale[t], step[j, 1, t] * scale[t], step[j, 2, t] * scale[t]
                angle = np.sqrt(vx * vx + vy * vy + vz * vz)
                unit = max(angle, 1e-300)
                axis[0, t], axis[1, t], axis[2, t] = vx / unit, vy / unit, vz / unit
                sine[t] = angle
            _sine_versine(sine, versine)
            # local = parent^T turn parent local, parent: the carrier's parent posed at this iteration's start
            p = carrier_parents[j]
            if T < FEW_FRAMES:          # one loop, the turn and the products in registers
                _turn_carrier(axis, sine, versine, rotation, p, current, j)
                continue
            _rodrigues_frames(axis, sine, versine, turn)
            if p < 0:
                _matmul_frames(turn, 0, current, j, product, False)
            else:
                _matmul_frames(rotation, p, turn, 0, left, True)
                _matmul_frames(left, 0, rotation, p, middle, False)
                _matmul_frames(middle, 0, current, j, product, False)
            for r in range(3):
                for c in range(3):
                    for t in range(T):
                        current[j, r, c, t] = product[0, r, c, t]
        if tolerance > 0.0:
            settled = False
            for t in range(T):
                if largest[t] < tolerance:
                    settled = True
            if settled:
                break
    return ran, largest


# Below this angle `_sine_versine` sums Taylor series (the terms left out are below 1e-19 of the result there);
# every step's turn is at most max_turn (0.3 rad in media/face_rig.py), so the library's sin and cos, scalar calls
# the compiler cannot vectorise, run only for larger turns.
SERIES_LIMIT = 0.5


@njit(cache=True, error_model="numpy")
def _sine_versine(angle, versine):
    """angle (T,) radians, >= 0 -> sin(angle) in place and versine (T,) = 1 - cos(angle): Taylor series in
    angle^2 by Horner's rule up to the 13th and 14th powers when every angle is below SERIES_LIMIT (a vectorised
    loop; within a few ulp of the library's, and 1 - cos without its cancellation), else np.sin / np.cos."""
    large = False
    for t in range(len(angle)):
        large = large or angle[t] >= SERIES_LIMIT
    if large:
        for t in range(len(angle)):
            a = angle[t]
            versine[t] = 1.0 - np.cos(a)
            angle[t] = np.sin(a)
        return
    for t in range(len(angle)):
        a = angle[t]
        a2 = a * a
        versine[t] = a2 * (0.5 - a2 * (1.0 / 24 - a2 * (1.0 / 720 - a2 * (1.0 / 40320 - a2 * (
            1.0 / 3628800 - a2 * (1.0 / 479001600 - a2 * (1.0 / 87178291200)))))))
        angle[t] = a * (1.0 - a2 * (1.0 / 6 - a2 * (1.0 / 120 - a2 * (1.0 / 5040 - a2 * (
            1.0 / 362880 - a2 * (1.0 / 39916800 - a2 * (1.0 / 6227020800)))))))


@njit(cache=True, error_model="numpy")
def _rodrigues_frames(axis, sine, versine, turn):
    """turn (1, 3, 3, T) = I + sin(a) K + (1 - cos(a)) K K, K the cross matrix of the unit axis (3, T); sine and
    versine (T,) hold sin(a) and 1 - cos(a).

    Each entry as the row-times-column product K K (a[r, 0] b[0, c] + a[r, 1] b[1, c] + a[r, 2] b[2, c]) and
    (delta + s K) + v KK summed it before, less the products
    with a zero of K (its diagonal): KK[r, r] = -(K's two squares), KK[r, c] one product, and the sums of
    one or two terms left are the same numbers up to the sign of a zero, which 1.0 + . and (0.0 + .) + .
    (never -0.0) absorb. Products and sums of two terms commute exactly; negations are exact. One loop per
    entry (one output, few inputs), so that each is vectorised."""
    for t in range(len(sine)):
        turn[0, 0, 0, t] = 1.0 - versine[t] * (axis[2, t] * axis[2, t] + axis[1, t] * axis[1, t])
    for t in range(len(sine)):
        turn[0, 1, 1, t] = 1.0 - versine[t] * (axis[2, t] * axis[2, t] + axis[0, t] * axis[0, t])
    for t in range(len(sine)):
        turn[0, 2, 2, t] = 1.0 - versine[t] * (axis[1, t] * axis[1, t] + axis[0, t] * axis[0, t])
    for t in range(len(sine)):
        turn[0, 0, 1, t] = (0.0 - sine[t] * axis[2, t]) + versine[t] * (axis[1, t] * axis[0, t])
    for t in range(len(sine)):
        turn[0, 1, 0, t] = (0.0 + sine[t] * axis[2, t]) + versine[t] * (axis[1, t] * axis[0, t])
    for t in range(len(sine)):
        turn[0, 0, 2, t] = (0.0 + sine[t] * axis[1, t]) + versine[t] * (axis[2, t] * axis[0, t])
    for t in range(len(sine)):
        turn[0, 2, 0, t] = (0.0 - sine[t] * axis[1, t]) + versine[t] * (axis[2, t] * axis[0, t])
    for t in range(len(sine)):
        turn[0, 1, 2, t] = (0.0 - sine[t] * axis[0, t]) + versine[t] * (axis[2, t] * axis[1, t])
    for t in range(len(sine)):
        turn[0, 2, 1, t] = (0.0 + sine[t] * axis[0, t]) + versine[t] * (axis[2, t] * axis[1, t])


@njit(cache=True, error_model="numpy")
def _matmul_frames(a, ja, b, jb, out, transpose):
    """out[0] = a[ja] b[jb] (a[ja]^T b[jb] where transpose) for 3 x 3 matrices of T frames, arrays (n, 3, 3, T),
    each entry a[r, 0] b[0, c] + a[r, 1] b[1, c] + a[r, 2] b[2, c] (a[0, r] b[0, c] + ...); out is neither a nor b. Indexed whole (no views: a view costs
    reference counting, more than these few products)."""
    for r in range(3):
        for c in range(3):
            if transpose:
                for t in range(out.shape[3]):
                    out[0, r, c, t] = (a[ja, 0, r, t] * b[jb, 0, c, t] + a[ja, 1, r, t] * b[jb, 1, c, t]
                                       + a[ja, 2, r, t] * b[jb, 2, c, t])
            else:
                for t in range(out.shape[3]):
                    out[0, r, c, t] = (a[ja, r, 0, t] * b[jb, 0, c, t] + a[ja, r, 1, t] * b[jb, 1, c, t]
                                       + a[ja, r, 2, t] * b[jb, 2, c, t])


@njit(cache=True, error_model="numpy")
def _turn_carrier(axis, sine, versine, rotation, p, current, j):
    """current[j] = turn current[j] (p < 0) or (rotation[p]^T turn) rotation[p] current[j], turn the Rodrigues
    matrix of `_rodrigues_frames` (axis (3, T), sine and versine (T,)), arrays (n, 3, 3, T): those entries and the
    `_matmul_frames` products, each summed as there, in one loop with each frame's numbers in registers."""
    for t in range(current.shape[3]):
        x, y, z, s, v = axis[0, t], axis[1, t], axis[2, t], sine[t], versine[t]
        b00 = 1.0 - v * (z * z + y * y)
        b11 = 1.0 - v * (z * z + x * x)
        b22 = 1.0 - v * (y * y + x * x)
        b01 = (0.0 - s * z) + v * (y * x)
        b10 = (0.0 + s * z) + v * (y * x)
        b02 = (0.0 + s * y) + v * (z * x)
        b20 = (0.0 - s * y) + v * (z * x)
        b12 = (0.0 - s * x) + v * (z * y)
        b21 = (0.0 + s * x) + v * (z * y)
        if p >= 0:
            a00, a01, a02 = rotation[p, 0, 0, t], rotation[p, 0, 1, t], rotation[p, 0, 2, t]
            a10, a11, a12 = rotation[p, 1, 0, t], rotation[p, 1, 1, t], rotation[p, 1, 2, t]
            a20, a21, a22 = rotation[p, 2, 0, t], rotation[p, 2, 1, t], rotation[p, 2, 2, t]
            l00 = a00 * b00 + a10 * b10 + a20 * b20          # left = rotation^T turn
            l01 = a00 * b01 + a10 * b11 + a20 * b21
            l02 = a00 * b02 + a10 * b12 + a20 * b22
            l10 = a01 * b00 + a11 * b10 + a21 * b20
            l11 = a01 * b01 + a11 * b11 + a21 * b21
            l12 = a01 * b02 + a11 * b12 + a21 * b22
            l20 = a02 * b00 + a12 * b10 + a22 * b20
            l21 = a02 * b01 + a12 * b11 + a22 * b21
            l22 = a02 * b02 + a12 * b12 + a22 * b22
            b00 = l00 * a00 + l01 * a10 + l02 * a20          # middle = left rotation, in the turn's place
            b01 = l00 * a01 + l01 * a11 + l02 * a21
            b02 = l00 * a02 + l01 * a12 + l02 * a22
            b10 = l10 * a00 + l11 * a10 + l12 * a20
            b11 = l10 * a01 + l11 * a11 + l12 * a21
            b12 = l10 * a02 + l11 * a12 + l12 * a22
            b20 = l20 * a00 + l21 * a10 + l22 * a20
            b21 = l20 * a01 + l21 * a11 + l22 * a21
            b22 = l20 * a02 + l21 * a12 + l22 * a22
        c00, c01, c02 = current[j, 0, 0, t], current[j, 0, 1, t], current[j, 0, 2, t]
        c10, c11, c12 = current[j, 1, 0, t], current[j, 1, 1, t], current[j, 1, 2, t]
        c20, c21, c22 = current[j, 2, 0, t], current[j, 2, 1, t], current[j, 2, 2, t]
        current[j, 0, 0, t] = b00 * c00 + b01 * c10 + b02 * c20
        current[j, 0, 1, t] = b00 * c01 + b01 * c11 + b02 * c21
        current[j, 0, 2, t] = b00 * c02 + b01 * c12 + b02 * c22
        current[j, 1, 0, t] = b10 * c00 + b11 * c10 + b12 * c20
        current[j, 1, 1, t] = b10 * c01 + b11 * c11 + b12 * c21
        current[j, 1, 2, t] = b10 * c02 + b11 * c12 + b12 * c22
        current[j, 2, 0, t] = b20 * c00 + b21 * c10 + b22 * c20
        current[j, 2, 1, t] = b20 * c01 + b21 * c11 + b22 * c21
        current[j, 2, 2, t] = b20 * c02 + b21 * c12 + b22 * c22


@njit(cache=True, error_model="numpy")
def _add_block_product(lever, nu, nw, totals):
    """totals (9, T) += B_u B_w^T row-major, for J's blocks B_u = -[u]x and B_w = -[w]x, u = lever[nu] and
    w = lever[nw] (3, T).

    Each entry is sum_s B_u[r, s] B_w[c, s], summed over s = 0, 1, 2 before; the terms with a zero of -[.]x
    (s = r or s = c) are exact zeros (+-0, the levers are finite) and are left out: a sum of one or two
    products is then the same number except perhaps the sign of a zero, which `totals` (sums that start at
    +0.0 and so never hold -0.0) absorbs. Negations are exact and x + (-y) is x - y, so the products of
    negated entries are written as differences."""
    for t in range(totals.shape[1]):
        x, y, z = lever[nu, 0, t], lever[nu, 1, t], lever[nu, 2, t]
        a, b, c = lever[nw, 0, t], lever[nw, 1, t], lever[nw, 2, t]
        totals[0, t] += z * c + y * b
        totals[1, t] -= y * a
        totals[2, t] -= z * a
        totals[3, t] -= x * b
        totals[4, t] += z * c + x * a
        totals[5, t] -= z * b
        totals[6, t] -= x * c
        totals[7, t] -= y * c
        totals[8, t] += y * b + x * a


@njit(cache=True, error_model="numpy")
def _solve_alone(totals, residual, i, damping2, solved):
    """solved[3 i:3 i + 3] (T frames) for a skinned bone that shares no carrier: its block of J J^T, totals (9, T)
    row-major, plus damping2 on the diagonal, solved against residual[3 i:3 i + 3] as the group solve does it
    (the block written symmetric from totals, so its lower triangle is totals' lower triangle, then
    `_solve_spd_frames` with n = 3), operation for operation, each frame in registers."""
    for t in range(totals.shape[1]):
        m00 = totals[0, t] + damping2
        m10 = totals[3, t]
        m11 = totals[4, t] + damping2
        m20 = totals[6, t]
        m21 = totals[7, t]
        m22 = totals[8, t] + damping2
        l00 = np.sqrt(m00)
        l10 = m10 / l00
        l20 = m20 / l00
        l11 = np.sqrt(m11 - l10 * l10)
        l21 = (m21 - l20 * l10) / l11
        l22 = np.sqrt((m22 - l20 * l20) - l21 * l21)
        y0 = residual[3 * i, t] / l00
        y1 = (residual[3 * i + 1, t] - l10 * y0) / l11
        y2 = ((residual[3 * i + 2, t] - l20 * y0) - l21 * y1) / l22
        x2 = y2 / l22
        x1 = (y1 - l21 * x2) / l11
        solved[3 * i, t] = ((y0 - l10 * x1) - l20 * x2) / l00
        solved[3 * i + 1, t] = x1
        solved[3 * i + 2, t] = x2


@njit(cache=True, error_model="numpy")
def _pose_frames(local, carrier_heads, carrier_parents, rotation, offset):
    """_pose for all frames: local (C, 3, 3, T) -> rotation (C, 3, 3, T), offset (C, 3, T)."""
    n_frames = local.shape[3]
    for j in range(len(carrier_parents)):
        p = carrier_parents[j]
        h0, h1, h2 = carrier_heads[j, 0], carrier_heads[j, 1], carrier_heads[j, 2]
        if p < 0:
            for r in range(3):
                for c in range(3):
                    for t in range(n_frames):
                        rotation[j, r, c, t] = local[j, r, c, t]
            for r in range(3):
                hr = carrier_heads[j, r]
                for t in range(n_frames):
                    moved = local[j, r, 0, t] * h0 + local[j, r, 1, t] * h1 + local[j, r, 2, t] * h2
                    offset[j, r, t] = hr - moved
        elif n_frames < FEW_FRAMES:     # one loop, as `_turn_carrier`
            _pose_child(local, j, p, h0, h1, h2, rotation, offset)
        else:
            for r in range(3):
                for c in range(3):
                    for t in range(n_frames):
                        rotation[j, r, c, t] = (rotation[p, r, 0, t] * local[j, 0, c, t] + rotation[p, r, 1, t] * local[j, 1, c, t]
                                                + rotation[p, r, 2, t] * local[j, 2, c, t])
            for r in range(3):
                for t in range(n_frames):
                    point = rotation[p, r, 0, t] * h0 + rotation[p, r, 1, t] * h1 + rotation[p, r, 2, t] * h2
                    moved = rotation[j, r, 0, t] * h0 + rotation[j, r, 1, t] * h1 + rotation[j, r, 2, t] * h2
                    offset[j, r, t] = offset[p, r, t] + point - moved


@njit(cache=True, error_model="numpy")
def _pose_child(local, j, p, h0, h1, h2, rotation, offset):
    """`_pose_frames` of carrier j whose parent is carrier p, head (h0, h1, h2): the same sums, one loop over the
    frames with each frame's rotation in registers."""
    for t in range(local.shape[3]):
        a00, a01, a02 = rotation[p, 0, 0, t], rotation[p, 0, 1, t], rotation[p, 0, 2, t]
        a10, a11, a12 = rotation[p, 1, 0, t], rotation[p, 1, 1, t], rotation[p, 1, 2, t]
        a20, a21, a22 = rotation[p, 2, 0, t], rotation[p, 2, 1, t], rotation[p, 2, 2, t]
        b00, b01, b02 = local[j, 0, 0, t], local[j, 0, 1, t], local[j, 0, 2, t]
        b10, b11, b12 = local[j, 1, 0, t], local[j, 1, 1, t], local[j, 1, 2, t]
        b20, b21, b22 = local[j, 2, 0, t], local[j, 2, 1, t], local[j, 2, 2, t]
        r00 = a00 * b00 + a01 * b10 + a02 * b20
        r01 = a00 * b01 + a01 * b11 + a02 * b21
        r02 = a00 * b02 + a01 * b12 + a02 * b22
        r10 = a10 * b00 + a11 * b10 + a12 * b20
        r11 = a10 * b01 + a11 * b11 + a12 * b21
        r12 = a10 * b02 + a11 * b12 + a12 * b22
        r20 = a20 * b00 + a21 * b10 + a22 * b20
        r21 = a20 * b01 + a21 * b11 + a22 * b21
        r22 = a20 * b02 + a21 * b12 + a22 * b22
        rotation[j, 0, 0, t], rotation[j, 0, 1, t], rotation[j, 0, 2, t] = r00, r01, r02
        rotation[j, 1, 0, t], rotation[j, 1, 1, t], rotation[j, 1, 2, t] = r10, r11, r12
        rotation[j, 2, 0, t], rotation[j, 2, 1, t], rotation[j, 2, 2, t] = r20, r21, r22
        offset[j, 0, t] = offset[p, 0, t] + (a00 * h0 + a01 * h1 + a02 * h2) - (r00 * h0 + r01 * h1 + r02 * h2)
        offset[j, 1, t] = offset[p, 1, t] + (a10 * h0 + a11 * h1 + a12 * h2) - (r10 * h0 + r11 * h1 + r12 * h2)
        offset[j, 2, t] = offset[p, 2, t] + (a20 * h0 + a21 * h1 + a22 * h2) - (r20 * h0 + r21 * h1 + r22 * h2)


@njit(cache=True, inline="always")
def _cholesky_remainder(matrix, i: int, j: int, total) -> None:
    """total[t] = matrix[i, j, t] - sum over k < j of matrix[i, k, t] matrix[j, k, t] for every frame t: the
    Cholesky factor's entry (i, j) before its division by the diagonal (its square on the diagonal)."""
    n_frames = matrix.shape[2]
    for t in range(n_frames):
        total[t] = matrix[i, j, t]
    for k in range(j):
        for t in range(n_frames):
            total[t] -= matrix[i, k, t] * matrix[j, k, t]


@njit(cache=True, error_model="numpy")
def _solve_spd_frames(matrix, rhs, n, total):
    """_solve_spd for all frames: matrix (>= n, >= n, T), rhs (>= n, T); total (T,) scratch."""
    n_frames = matrix.shape[2]
    for j in range(n):
        _cholesky_remainder(matrix, j, j, total)
        for t in range(n_frames):
            matrix[j, j, t] = np.sqrt(total[t])
        for i in range(j + 1, n):
            _cholesky_remainder(matrix, i, j, total)
            for t in range(n_frames):
                matrix[i, j, t] = total[t] / matrix[j, j, t]
    for i in range(n):
        for t in range(n_frames):
            total[t] = rhs[i, t]
        for k in range(i):
            for t in range(n_frames):
                total[t] -= matrix[i, k, t] * rhs[k, t]
        for t in range(n_frames):
            rhs[i, t] = total[t] / matrix[i, i, t]
    for i in range(n - 1, -1, -1):
        for t in range(n_frames):
            total[t] = rhs[i, t]
        for k in range(i + 1, n):
            for t in range(n_frames):
                total[t] -= matrix[k, i, t] * rhs[k, t]
        for t in range(n_frames):
            rhs[i, t] = total[t] / matrix[i, i, t]


@njit(cache=True)
def bone_turns(arms, head_moved, tail_moved):
    """Rotation matrices (T, S, 3, 3) turning each skinned bone so that its tail moves by its own
    displacement relative to its head: media/rotations.py `between(arm, arm + tail - head)` then
    `to_matrix`, compiled.

    arms (S, 3) head -> tail at rest; head_moved, tail_moved (T, S, 3) metres. between: both directions
    made unit, q = (1 + a.b, a x b) (or a half turn about a x (1, 0, 0), a x (0, 1, 0) where |a_x| >= 0.9, for
    opposite directions) made unit, then its rotation matrix.
    """
    n_frames, n_skinned = head_moved.shape[0], head_moved.shape[1]
    out = np.empty((n_frames, n_skinned, 3, 3))
    for t in range(n_frames):
        for i in range(n_skinned):
            a0, a1, a2 = arms[i, 0], arms[i, 1], arms[i, 2]
            b0 = (a0 + tail_moved[t, i, 0]) - head_moved[t, i, 0]
            b1 = (a1 + tail_moved[t, i, 1]) - head_moved[t, i, 1]
            b2 = (a2 + tail_moved[t, i, 2]) - head_moved[t, i, 2]
            na = np.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
            nb = np.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
            a0, a1, a2 = a0 / na, a1 / na, a2 / na
            b0, b1, b2 = b0 / nb, b1 / nb, b2 / nb
            dot = a0 * b0 + a1 * b1 + a2 * b2
            if dot < -1.0 + 1e-12:
                if abs(a0) < 0.9:
                    h0, h1, h2 = 1.0, 0.0, 0.0
                else:
                    h0, h1, h2 = 0.0, 1.0, 0.0
                w, x, y, z = 0.0, a1 * h2 - a2 * h1, a2 * h0 - a0 * h2, a0 * h1 - a1 * h0
            else:
                w, x, y, z = 1.0 + dot, a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
            norm = np.sqrt(w * w + x * x + y * y + z * z)
            w, x, y, z = w / norm, x / norm, y / norm, z / norm
            xx, yy, zz = x * x, y * y, z * z
            xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
            out[t, i, 0, 0], out[t, i, 0, 1], out[t, i, 0, 2] = 1.0 - 2.0 * (yy + zz), 2.0 * (xy - zw), 2.0 * (xz + yw)
            out[t, i, 1, 0], out[t, i, 1, 1], out[t, i, 1, 2] = 2.0 * (xy + zw), 1.0 - 2.0 * (xx + zz), 2.0 * (yz - xw)
            out[t, i, 2, 0], out[t, i, 2, 1], out[t, i, 2, 2] = 2.0 * (xz - yw), 2.0 * (yz + xw), 1.0 - 2.0 * (xx + yy)
    return out

