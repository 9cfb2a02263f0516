"""Numba kernels of the FAPs -> face-bone path (media/face_rig.py `face_bone_rotations`), as few calls per
clip: `face_targets` (every bone's displacement from the FAP values), `turns` (the lids' turns) and
`eye_rotations`: compiled for speed (one pass over frames instead of dozens of small NumPy calls).
tests/test_face_rig_speed.py compares them with the NumPy rig (media/face_rig.py `_face_bone_rotations_numpy`) on
real FAPs of several languages within 1e-12 per quaternion component.
"""
import math

import numpy as np
from numba import njit

from media.rotation_loops import from_rotvec


@njit(cache=True)
def face_targets(values, cols, fapu, shares, angle_unit):
    """The face rig's displacements from FAP values (media/face_rig.py `_turned_bones` and `_carried_bones`
    compiled).

    values (T, 68) float64 FAP values; cols (27, 2) int64: FAP columns (index = id - 1) per name of
    media/face_rig.py `_TARGET_FAPS`, L then R (one-sided names repeat); fapu (5,) irisd, es, ens, mns, mw
    metres; shares (4,) corner shares of oris03.L/R, oris07.L/R. Returns turned (5, T, 3) the jaw's and
    per side the upper and lower lid's displacements, eye_angles (4, T) yaw L, pitch L, yaw R, pitch R
    (radians: the FAP values times angle_unit), head and tail (T, 11, 3) of the head-carried bones, jaw (T, 3, 3) of the jaw-carried ones.
    """
    n = values.shape[0]
    irisd, es, ens, mns, mw = fapu[0], fapu[1], fapu[2], fapu[3], fapu[4]
    turned = np.zeros((5, n, 3))
    eye = np.empty((4, n))
    head = np.zeros((n, 11, 3))
    tail = np.zeros((n, 11, 3))
    jaw = np.zeros((n, 3, 3))
    for t in range(n):
        v = values[t]
        opening = max(v[cols[0, 0]], 0.0)
        turned[0, t, 0] = -v[cols[1, 0]] * mw
        turned[0, t, 1] = -opening * mns
        push_t = v[cols[10, 0]] * mns
        push_b = v[cols[11, 0]] * mns
        nose_lift = v[cols[12, 0]] * ens
        for s in range(2):
            outward = 1.0 if s == 0 else -1.0
            turned[1 + 2 * s, t, 1] = -v[cols[2, s]] * irisd
            turned[2 + 2 * s, t, 1] = v[cols[3, s]] * irisd
            eye[2 * s, t] = v[cols[4, s]] * angle_unit
            eye[2 * s + 1, t] = v[cols[5, s]] * angle_unit
            corner_x = outward * ((v[cols[13, s]] + v[cols[14, s]]) / 2) * mw
            corner_y = ((v[cols[15, s]] + v[cols[16, s]]) / 2) * mns
            lift_x, lift_y, lift_z = corner_x * 0.0, corner_y * 1.0, 0.0 * 0.0
            squeeze = -outward * v[cols[6, s]] * es
            b = 4 * s
            upper, lower = shares[s], shares[2 + s]
            for moved in (head, tail):
                moved[t, b, 0], moved[t, b, 1] = corner_x, corner_y
                moved[t, b + 1, 0] = outward * v[cols[7, s]] * es
                moved[t, b + 1, 1] = max(v[cols[8, s]], 0.0) * ens
                moved[t, b + 2, 0] = squeeze
                moved[t, 8, 1], moved[t, 8, 2] = -((v[cols[17, 0]] + v[cols[18, 0]]) / 2) * mns, push_t
                moved[t, 9 + s, 0] = 0.0 + upper * lift_x
                moved[t, 9 + s, 1] = -((v[cols[19, s]] + v[cols[20, s]]) / 2) * mns + upper * lift_y
                moved[t, 9 + s, 2] = push_t + upper * lift_z
            head[t, b + 2, 1] = v[cols[9, s]] * ens
            tail[t, b + 2, 1] = v[cols[21, s]] * ens
            head[t, b + 3, 1] = nose_lift
            tail[t, b + 3, 0] = 0.0 + outward * v[cols[22, s]] * ens
            tail[t, b + 3, 1] = nose_lift + 0.0
            tail[t, b + 3, 2] = 0.0 + 0.0
            jaw[t, 1 + s, 0] = 0.0 + lower * lift_x
            jaw[t, 1 + s, 1] = ((v[cols[23, s]] + v[cols[24, s]]) / 2) * mns + lower * lift_y
            jaw[t, 1 + s, 2] = push_b + lower * lift_z
        jaw[t, 0, 1] = ((v[cols[25, 0]] + v[cols[26, 0]]) / 2) * mns
        jaw[t, 0, 2] = push_b
    return turned, eye, head, tail, jaw


@njit(cache=True)
def eye_rotations(eye_angles):
    """(2, T, 4) quaternions (w, x, y, z) of the eyeballs, L then R, from eye_angles (4, T) radians (yaw L, pitch L,
    yaw R, pitch R): per eye the yaw about +Y times the pitch about +X, as media/face_rig.py did it in NumPy
    (from_axis_angle of the unit axes: rotvec (0 a, 1 a, 0 a) or (1 a, 0 a, 0 a), then rotations.multiply's
    Hamilton product)."""
    n = eye_angles.shape[1]
    rotvec = np.empty((4 * n, 3))
    for k in range(4):
        about_y = k % 2 == 0
        for t in range(n):
            a = eye_angles[k, t]
            row = k * n + t
            if about_y:
                rotvec[row, 0], rotvec[row, 1], rotvec[row, 2] = 0.0 * a, 1.0 * a, 0.0 * a
            else:
                rotvec[row, 0], rotvec[row, 1], rotvec[row, 2] = 1.0 * a, 0.0 * a, 0.0 * a
    q = from_rotvec(rotvec)
    out = np.empty((2, n, 4))
    for e in range(2):
        for t in range(n):
            aw, ax, ay, az = q[2 * e * n + t, 0], q[2 * e * n + t, 1], q[2 * e * n + t, 2], q[2 * e * n + t, 3]
            bw, bx, by, bz = (q[(2 * e + 1) * n + t, 0], q[(2 * e + 1) * n + t, 1], q[(2 * e + 1) * n + t, 2],
                              q[(2 * e + 1) * n + t, 3])
            out[e, t, 0] = aw * bw - ax * bx - ay * by - az * bz
            out[e, t, 1] = aw * bx + ax * bw + ay * bz - az * by
            out[e, t, 2] = aw * by - ax * bz + ay * bw + az * bx
            out[e, t, 3] = aw * bz + ax * by - ay * bx + az * bw
    return out


@njit(cache=True)
def turns(arms, reach, displacements):
    """media/face_rig.py `_turns` compiled: the turns about each pivot that move the point at arms (N, 3) metres
    from it (reach (N,) their lengths) by displacements (N, T, 3) metres -> (N, T, 4) quaternions (w, x, y, z). Per
    frame: the direction d of the displacement (its length floored at 1e-300), along = d . arm, across = |arm -
    along d|, the angle atan2(across, along) - arccos(clip((|displacement| + along) / reach, -1, 1)) about the
    unit axis arm x d (the identity where they are parallel)."""
    n, m = displacements.shape[0], displacements.shape[1]
    rotvec = np.empty((n * m, 3))
    for a in range(n):
        a0, a1, a2 = arms[a, 0], arms[a, 1], arms[a, 2]
        for t in range(m):
            x, y, z = displacements[a, t, 0], displacements[a, t, 1], displacements[a, t, 2]
            distance = math.sqrt(x * x + y * y + z * z)
            floor = max(distance, 1e-300)
            b0, b1, b2 = x / floor, y / floor, z / floor
            along = (b0 * a0 + b1 * a1) + b2 * a2
            c0, c1, c2 = a0 - along * b0, a1 - along * b1, a2 - along * b2
            across = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
            ratio = min(max((distance + along) / reach[a], -1.0), 1.0)
            angle = math.atan2(across, along) - math.acos(ratio)
            x, y, z = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
            norm = max(math.sqrt(x * x + y * y + z * z), 1e-300)
            row = a * m + t
            rotvec[row, 0], rotvec[row, 1], rotvec[row, 2] = x / norm * angle, y / norm * angle, z / norm * angle
    return from_rotvec(rotvec).reshape((n, m, 4))
