"""Triangle rasterizer: z-buffer, per-pixel part label and triangle id, two looks.

One entry point, `rasterize`, with three bodies (NumPy here, the oracle; Warp in kernels/raster_warp.py;
OpenCL below) that follow the same steps, with the same arithmetic and the same constants:

1. project: each vertex to window coordinates, snapped to 1/SUBPIXEL pixel (integers), and depth in [0, 1];
2. per-triangle setup and bounding box: drop triangles with a vertex behind the eye or far off-screen,
   degenerate ones and (when culling) back faces; clip its bounding box to the image. The Warp and OpenCL
   bodies shrink the box to the pixel centres it holds and drop the triangle when it holds none
   (sub-pixel or off-image triangles, about half of the avatar's front faces at 352x288): coverage is
   only ever tested at pixel centres, so this skips work without changing a pixel;
3. edge functions with the top-left rule: coverage is decided with exact integer edge functions at
   pixel centres, so neighbouring triangles never share or miss a pixel and every backend covers
   the same pixels;
4. depth test: each covered pixel takes an atomic minimum of a 64-bit key `depth * 2^32 + triangle`,
   so depth ties resolve to the lower triangle id whatever the thread order (one pass, deterministic);
5. resolve: each pixel decodes its key into triangle id, label, depth and colour (the Warp and OpenCL
   bodies also reset the key there, so the next frame needs no clearing pass).

Speed, chosen here after measuring on CPU devices (Warp-CPU, PoCL): one work item per triangle (per run
of triangles on Warp-CPU, whose threads run one after another) with the 64-bit atomic minimum, rather
than tiles with per-tile triangle lists. The avatar's triangles cover a few pixels each, so binning
them would add a pass and a second setup per triangle for no saving in the raster loop, and CPU
atomics on distinct pixels are cheap. What the frames spent time on instead: per-thread launch cost,
kernel arguments packed again every frame (recorded launches now), bounding-box pixels whose
centres lie outside the triangle, a clearing pass, one host copy per output (now one in all), and on Warp
a resolve pass that rewrote every pixel (now only the rows' spans that were or are drawn).

Shaded look: a `vertex_normals` pass sums each vertex's area-weighted face normals in ascending triangle order
(CSR from `vertex_triangles`, so every backend adds in the same order), and the resolve lights each pixel with the
normals interpolated at its centre (barycentric weights from the integer edge functions), normalised:
ambient + diffuse * max(n . l, 0). Per-face light looked faceted at 1280x720.

Looks: "shaded" (Lambert per pixel on a per-triangle albedo, uniform background) and
"flat" (seed 000 §4.2.2's modified appearance: one uniform colour per part, no light, so masks can
be read back by colour). Labels are always hard (no anti-aliasing).
"""

import functools
import types
from typing import NamedTuple

import numpy as np

from kernels import backends
from kernels._arrays import UploadCache, as_array, check_indices_once, immutable, is_immutable
from kernels.errors import KernelError

LOOKS = ("shaded", "flat")

# The raster's constants, written once: the NumPy body uses them as they are, kernels/raster_warp.py
# as wp.constant, and the OpenCL source receives them as #defines generated from them.
SUBPIXEL = np.int64(256)               # fixed-point steps per pixel
HALF_SUBPIXEL = SUBPIXEL // 2          # a pixel centre, in fixed-point steps from the pixel's corner
MIN_CLIP_W = np.float32(1e-6)          # vertices with clip w below this (at or behind the eye) drop their triangles
GUARD_PIXELS = np.float32(32768.0)     # vertices farther off-screen than this (pixels) drop their triangles
DEPTH_SCALE = np.float32(2**31)        # depth in [0, 1] -> 31-bit integer in the key's high word
ID_SCALE = np.int64(2**32)             # key = depth code * ID_SCALE + triangle id
EMPTY_KEY = np.int64(2**63 - 1)        # no triangle covers the pixel

# Colours are indexed by part label (0 background, 1 body/clothes, 2 head, 3 left hand, 4 right hand).
FLAT_PALETTE = immutable(np.array([[0, 0, 0], [0, 0, 255], [255, 0, 0], [0, 255, 0], [255, 255, 0]], dtype=np.uint8))
SHADED_ALBEDO = immutable(np.array([[0, 0, 0], [46, 52, 70], [226, 176, 146], [226, 176, 146], [226, 176, 146]],
                                   dtype=np.uint8))
STUDIO_BACKGROUND = immutable(np.array([92, 112, 128], dtype=np.uint8))
KEY_LIGHT = np.array([0.35, 0.45, 1.0])            # direction towards the light, world (avatar faces +Z)
AMBIENT, DIFFUSE = 0.30, 0.75
_LIGHT = np.array([*(KEY_LIGHT / np.linalg.norm(KEY_LIGHT)), AMBIENT, DIFFUSE], dtype=np.float32)   # unit l, a, d
_LIGHT.flags.writeable = False


def rasterize(positions, triangles, triangle_part, camera, width: int, height: int, *, look: str = "shaded",
              triangle_colour=None, palette=None, background=None, cull_back_faces: bool = True,
              backend: str = "auto"):
    """Render a triangle mesh.

    positions: (V, 3) float32 world positions, metres. triangles: (F, 3) int32, counter-clockwise
    seen from outside. triangle_part: (F,) uint8 part label. camera: (4, 4) float32 world -> clip
    matrix (kernels.camera.view_projection). width, height: image size in pixels.
    look: "shaded" or "flat". triangle_colour: (F, 3) uint8 albedo for the shaded look (default:
    SHADED_ALBEDO by part). palette: (P, 3) uint8 colour per label for the flat look (default
    FLAT_PALETTE). background: (3,) uint8 shaded-look background (default STUDIO_BACKGROUND).
    cull_back_faces: skip triangles facing away (right for closed meshes).
    Returns rgb (H, W, 3) uint8, labels (H, W) uint8 (0 where empty), triangle_id (H, W) int32
    (-1 where empty), depth (H, W) float32 window depth in [0, 1] (inf where empty).
    """
    positions = as_array("positions", positions, np.float32, (None, 3))
    scene = checked_scene(positions, triangles, triangle_part, camera, width, height, look=look,
                          triangle_colour=triangle_colour, palette=palette, background=background,
                          cull_back_faces=cull_back_faces)
    if not np.all(np.isfinite(positions)):
        raise KernelError(NOT_FINITE)
    return _IMPLEMENTATIONS[backends.resolve(backend)].render(scene)


NOT_FINITE = "positions hold NaN or infinite values"


def checked_scene(positions: np.ndarray, triangles, triangle_part, camera, width: int, height: int, *,
                  look: str = "shaded", triangle_colour=None, palette=None, background=None,
                  cull_back_faces: bool = True) -> "_Scene":
    """rasterize's arguments checked (raises KernelError) into a _Scene; positions: (V, 3) float32 array
    whose values are not looked at (the caller checks them, or fills the device's copy itself)."""
    if look not in LOOKS:
        raise KernelError(f"unknown look {look!r}: choose shaded or flat")
    if not (isinstance(width, (int, np.integer)) and isinstance(height, (int, np.integer))
            and 1 <= width <= 8192 and 1 <= height <= 8192):
        raise KernelError(f"image size must be whole pixels in [1, 8192], got {width}x{height}")
    triangles = as_array("triangles", triangles, np.int32, (None, 3))
    triangle_part = as_array("triangle_part", triangle_part, np.uint8, (len(triangles),))
    camera = as_array("camera", camera, np.float32, (4, 4))
    check_indices_once("triangles", triangles, len(positions))
    palette = as_array("palette", FLAT_PALETTE if palette is None else palette, np.uint8, (None, 3))
    check_indices_once("triangle_part", triangle_part, len(palette))
    if look == "shaded":
        colour = (SHADED_ALBEDO[np.minimum(triangle_part, len(SHADED_ALBEDO) - 1)] if triangle_colour is None
                  else triangle_colour)
        colour = as_array("triangle_colour", colour, np.uint8, (len(triangles), 3))
        background = as_array("background", STUDIO_BACKGROUND if background is None else background, np.uint8, (3,))
    else:
        colour = _unlit(len(triangles))
        background = palette[0].copy()
    adjacency = vertex_triangles(triangles, len(positions)) if look == "shaded" else _NO_ADJACENCY
    return _Scene(positions, triangles, triangle_part, camera, int(width), int(height), look == "shaded",
                  colour, palette, background, _LIGHT, bool(cull_back_faces), adjacency)


_NO_ADJACENCY = (immutable(np.zeros(1, np.int32)), immutable(np.zeros(1, np.int32)))
_ADJACENCY: dict[int, tuple] = {}


def vertex_triangles(triangles: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """The triangles around each vertex, as CSR: indptr (V + 1,) int32 and triangle ids (3F,) int32, ascending
    within a vertex (the order in which every backend sums a vertex's normal). Immutable arrays; kept per
    immutable triangles array (the avatar's), recomputed for a writeable one."""
    key = id(triangles)
    hit = _ADJACENCY.get(key)
    if hit is not None and hit[0] is triangles and hit[1] == n_vertices:
        return hit[2]
    flat = triangles.reshape(-1).astype(np.int64)
    order = np.argsort(flat, kind="stable")              # stable: a vertex's triangles stay in ascending order
    counts = np.bincount(flat, minlength=n_vertices)
    indptr = np.zeros(n_vertices + 1, np.int32)
    np.cumsum(counts, out=indptr[1:])
    adjacency = (immutable(indptr), immutable((order // 3).astype(np.int32)))
    if is_immutable(triangles):
        if len(_ADJACENCY) >= 8:
            _ADJACENCY.pop(next(iter(_ADJACENCY)))
        _ADJACENCY[key] = (triangles, n_vertices, adjacency)
    return adjacency


@functools.lru_cache(maxsize=8)
def _unlit(n_triangles: int) -> np.ndarray:
    """(F, 3) uint8 zeros, the flat look's unused albedo: immutable, so the kernels upload it once."""
    return immutable(np.zeros((n_triangles, 3), np.uint8))


def render_scene(scene: "_Scene", backend: str = "auto", fill_positions=None):
    """Draw a checked scene (`checked_scene`); rasterize's outputs. fill_positions (OpenCL only): a function
    (queue, buffer) that enqueues the scene's positions into the device buffer in place of uploading
    scene.positions (kernels/skinned_raster.py's skinning); positions that are not finite then raise
    KernelError after the frame."""
    name = backends.resolve(backend)
    if fill_positions is None:
        return _IMPLEMENTATIONS[name].render(scene)
    if name != "opencl":
        raise KernelError(f"fill_positions needs the opencl backend, not {name}")
    return _IMPLEMENTATIONS[name].render(scene, fill_positions)


class _Scene:
    """Checked arguments of one rasterize call."""

    def __init__(self, positions, triangles, triangle_part, camera, width, height, shaded, colour, palette,
                 background, light, cull, adjacency):
        self.positions, self.triangles, self.triangle_part, self.camera = positions, triangles, triangle_part, camera
        self.adjacency = adjacency          # vertex_triangles(triangles) for the shaded look
        self.width, self.height, self.shaded = width, height, shaded
        self.colour, self.palette, self.background, self.light, self.cull = colour, palette, background, light, cull


# --- NumPy: the oracle ----------------------------------------------------------------------------
# The same steps as the Warp and OpenCL bodies, each over all vertices, triangles or pixels at once:
# project, per-triangle setup and bounding box, edge functions with the top-left rule, depth test, resolve.

def _project(positions, camera, width, height):
    """Kernel `project`: window coordinates in 1/SUBPIXEL pixel (int64), depth (float32) in [0, 1]
    where on screen, and validity (V,) bool; float32 arithmetic throughout, as on the devices."""
    x, y, z = positions[:, 0], positions[:, 1], positions[:, 2]
    m = camera
    cx, cy, cz, cw = (m[r, 0] * x + m[r, 1] * y + m[r, 2] * z + m[r, 3] for r in range(4))
    valid = cw > MIN_CLIP_W
    w = np.where(valid, cw, np.float32(1))
    half = np.float32(0.5)
    window_x = (cx / w * half + half) * np.float32(width)
    window_y = (half - cy / w * half) * np.float32(height)
    depth = (cz / w * half + half).astype(np.float32)
    valid &= (np.abs(window_x) < GUARD_PIXELS) & (np.abs(window_y) < GUARD_PIXELS)
    fixed_x = np.where(valid, np.floor(window_x * np.float32(SUBPIXEL) + half), 0).astype(np.int64)
    fixed_y = np.where(valid, np.floor(window_y * np.float32(SUBPIXEL) + half), 0).astype(np.int64)
    return fixed_x, fixed_y, depth, valid


def _edge(ax, ay, bx, by, px, py):
    """Integer edge function of edge a->b at p: positive on the inner side of a counter-clockwise walk."""
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


def _top_left_bias(ax, ay, bx, by):
    """0 where pixels exactly on the edge belong to the triangle (top or left edge), else 1."""
    dx, dy = bx - ax, by - ay
    return np.where((dy < 0) | ((dy == 0) & (dx > 0)), 0, 1)


def _face_normals(positions, triangles):
    """(F,) x, y, z float32 of each face's area-weighted normal (p1 - p0) x (p2 - p0), unnormalised."""
    p0, p1, p2 = positions[triangles[:, 0]], positions[triangles[:, 1]], positions[triangles[:, 2]]
    e1, e2 = p1 - p0, p2 - p0
    return (e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1], e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2],
            e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def _vertex_normals(positions, triangles, adjacency):
    """Kernel `vertex_normals`: (V, 3) float32 unit normal of each vertex, the sum of its faces' area-weighted
    normals in ascending triangle order (zero where that sum is zero)."""
    indptr, ids = adjacency
    face = _face_normals(positions, triangles)
    degree = np.diff(indptr)
    total = [np.zeros(len(positions), np.float32) for _ in range(3)]
    for k in range(int(degree.max(initial=0))):      # the k-th triangle of every vertex that has one
        v = np.flatnonzero(degree > k)
        t = ids[indptr[v] + k]
        for axis in range(3):
            total[axis][v] = total[axis][v] + face[axis][t]
    x, y, z = total
    length = np.sqrt(x * x + y * y + z * z)
    safe = np.where(length > 0, length, np.float32(1))
    return np.stack([np.where(length > 0, x / safe, np.float32(0)), np.where(length > 0, y / safe, np.float32(0)),
                     np.where(length > 0, z / safe, np.float32(0))], axis=1).astype(np.float32)


def _pixel_shade(s: "_Scene", t, px, py, fixed_x, fixed_y, normals):
    """(N,) float32 Lambert factor at pixel centres (px, py) (N,) of triangles t (N,): the vertex normals
    interpolated with the pixel's barycentric weights (integer edge functions over the integer area), normalised,
    ambient + diffuse * max(n . l, 0); a back face drawn (area > 0 in window space) turns its normal round."""
    i0, i1, i2 = s.triangles[t, 0], s.triangles[t, 1], s.triangles[t, 2]
    x0, y0, x1, y1, x2, y2 = fixed_x[i0], fixed_y[i0], fixed_x[i1], fixed_y[i1], fixed_x[i2], fixed_y[i2]
    cx, cy = px * SUBPIXEL + HALF_SUBPIXEL, py * SUBPIXEL + HALF_SUBPIXEL
    area = _edge(x0, y0, x1, y1, x2, y2).astype(np.float32)
    l1 = _edge(x2, y2, x0, y0, cx, cy).astype(np.float32) / area
    l2 = _edge(x0, y0, x1, y1, cx, cy).astype(np.float32) / area
    n0, n1, n2 = normals[i0], normals[i1], normals[i2]
    n = [n0[:, k] + l1 * (n1[:, k] - n0[:, k]) + l2 * (n2[:, k] - n0[:, k]) for k in range(3)]
    length = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    light = s.light
    towards = n[0] * light[0] + n[1] * light[1] + n[2] * light[2]
    cosine = np.where(length > 0, towards / np.where(length > 0, length, np.float32(1)), np.float32(0))
    cosine = np.where(area > 0, -cosine, cosine)
    return (light[3] + light[4] * np.maximum(cosine, np.float32(0))).astype(np.float32)


class _Walk(NamedTuple):
    """The triangles the raster step walks, after the kernel's per-triangle setup (one row each).

    t: (N,) triangle ids; ax..cy: (N,) int64 fixed-point vertices in walking order a, b, c
    (counter-clockwise, so edge functions are positive inside); z0, dz1, dz2: (N,) float32 depth of
    the first vertex and the differences to the other two (original order after the flip);
    inverse_area: (N,) float32; xmin..ymax: (N,) int64 pixel bounding box; flipped: (N,) bool.
    """
    t: np.ndarray
    ax: np.ndarray
    ay: np.ndarray
    bx: np.ndarray
    by: np.ndarray
    cx: np.ndarray
    cy: np.ndarray
    z0: np.ndarray
    dz1: np.ndarray
    dz2: np.ndarray
    inverse_area: np.ndarray
    xmin: np.ndarray
    xmax: np.ndarray
    ymin: np.ndarray
    ymax: np.ndarray
    flipped: np.ndarray


def _setup_triangles(s: _Scene, fixed_x, fixed_y, depth, valid) -> _Walk:
    """Kernel `raster`, per-triangle part: drop triangles with a vertex off limits, degenerate ones and
    (when culling) back faces; turn drawn back faces clockwise like front faces; clip the bounding box."""
    i0, i1, i2 = s.triangles[:, 0], s.triangles[:, 1], s.triangles[:, 2]
    x0, y0, x1, y1, x2, y2 = fixed_x[i0], fixed_y[i0], fixed_x[i1], fixed_y[i1], fixed_x[i2], fixed_y[i2]
    z0, z1, z2 = depth[i0], depth[i1], depth[i2]
    area = _edge(x0, y0, x1, y1, x2, y2)
    keep = valid[i0] & valid[i1] & valid[i2] & (area != 0)
    flipped = area > 0                  # window y points down: front faces turn clockwise, area < 0
    if s.cull:
        keep &= ~flipped
    x1, x2 = np.where(flipped, x2, x1), np.where(flipped, x1, x2)
    y1, y2 = np.where(flipped, y2, y1), np.where(flipped, y1, y2)
    z1, z2 = np.where(flipped, z2, z1), np.where(flipped, z1, z2)
    area = -np.abs(area)
    keep &= (np.maximum(np.maximum(x0, x1), x2) >= 0) & (np.maximum(np.maximum(y0, y1), y2) >= 0)
    xmin = np.maximum(np.minimum(np.minimum(x0, x1), x2), 0) // SUBPIXEL
    xmax = np.minimum(np.maximum(np.maximum(x0, x1), x2) // SUBPIXEL, s.width - 1)
    ymin = np.maximum(np.minimum(np.minimum(y0, y1), y2), 0) // SUBPIXEL
    ymax = np.minimum(np.maximum(np.maximum(y0, y1), y2) // SUBPIXEL, s.height - 1)
    keep &= (xmax >= xmin) & (ymax >= ymin)
    t = np.flatnonzero(keep)
    # walking order a, b, c = v0, v2, v1 turns counter-clockwise: edge functions are positive inside
    return _Walk(t, x0[t], y0[t], x2[t], y2[t], x1[t], y1[t], z0[t], (z1 - z0)[t], (z2 - z0)[t],
                 np.float32(1) / (-area[t]).astype(np.float32), xmin[t], xmax[t], ymin[t], ymax[t], flipped[t])


def _bounding_box_pixels(walk: _Walk):
    """Every pixel of every bounding box: row k of `walk` (N,) and pixel column px, row py (N,) int64."""
    span_x = walk.xmax - walk.xmin + 1
    counts = span_x * (walk.ymax - walk.ymin + 1)
    k = np.repeat(np.arange(len(walk.t)), counts)
    offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    return k, walk.xmin[k] + offset % span_x[k], walk.ymin[k] + offset // span_x[k]


class _NumpyRaster:
    def render(self, s: _Scene):
        fixed_x, fixed_y, depth, valid = _project(s.positions, s.camera, s.width, s.height)
        walk = _setup_triangles(s, fixed_x, fixed_y, depth, valid)
        k, px, py = _bounding_box_pixels(walk)
        # edge functions at the pixel centres, with the top-left rule
        centre_x, centre_y = px * SUBPIXEL + HALF_SUBPIXEL, py * SUBPIXEL + HALF_SUBPIXEL
        ax, ay, bx, by, cx, cy = walk.ax[k], walk.ay[k], walk.bx[k], walk.by[k], walk.cx[k], walk.cy[k]
        e0 = _edge(bx, by, cx, cy, centre_x, centre_y)
        e1 = _edge(cx, cy, ax, ay, centre_x, centre_y)
        e2 = _edge(ax, ay, bx, by, centre_x, centre_y)
        inside = ((e0 >= _top_left_bias(bx, by, cx, cy)) & (e1 >= _top_left_bias(cx, cy, ax, ay))
                  & (e2 >= _top_left_bias(ax, ay, bx, by)))
        k, px, py, e1, e2 = k[inside], px[inside], py[inside], e1[inside], e2[inside]
        # depth test: interpolate, keep [0, 1], atomic minimum of the key depth * ID_SCALE + triangle
        l1 = e2.astype(np.float32) * walk.inverse_area[k]
        l2 = e1.astype(np.float32) * walk.inverse_area[k]
        z = walk.z0[k] + l1 * walk.dz1[k] + l2 * walk.dz2[k]
        in_range = (z >= 0) & (z <= 1)
        key = (z[in_range] * DEPTH_SCALE).astype(np.int64) * ID_SCALE + walk.t[k[in_range]]
        keys = np.full(s.width * s.height, EMPTY_KEY, dtype=np.int64)
        np.minimum.at(keys, py[in_range] * s.width + px[in_range], key)
        normals = _vertex_normals(s.positions, s.triangles, s.adjacency) if s.shaded else None
        return _resolve(s, keys, fixed_x, fixed_y, normals)


def _resolve(s: _Scene, keys, fixed_x, fixed_y, normals):
    """Kernel `resolve`: each pixel's key -> triangle id, label, depth and colour (shaded look: the albedo of
    its triangle lit with the interpolated vertex normals, _pixel_shade)."""
    W, H = s.width, s.height
    covered = keys != EMPTY_KEY
    triangle_id = np.where(covered, keys % ID_SCALE, -1).astype(np.int32)
    depth = np.where(covered, (keys // ID_SCALE).astype(np.float32) / DEPTH_SCALE, np.float32(np.inf))
    labels = np.where(covered, s.triangle_part[np.maximum(triangle_id, 0)], 0).astype(np.uint8)
    if not s.shaded:
        rgb = s.palette[labels]
    else:
        rgb = np.broadcast_to(s.background, (W * H, 3)).copy()
        pixel = np.flatnonzero(covered)
        t = triangle_id[pixel]
        shade = _pixel_shade(s, t, pixel % W, pixel // W, fixed_x, fixed_y, normals)
        value = s.colour[t].astype(np.float32) * shade[:, None] + np.float32(0.5)
        rgb[pixel] = np.minimum(value, np.float32(255)).astype(np.uint8)
    return rgb.reshape(H, W, 3), labels.reshape(H, W), triangle_id.reshape(H, W), depth.reshape(H, W)


# --- Warp (bodies in kernels/raster_warp.py, imported on first use) ------------------------------

class _WarpRaster:
    """Device buffers and recorded launches are kept per mesh and image size, so a frame packs no kernel
    arguments again (and sets the camera, light and look only when they change); the mesh topology,
    parts and colours upload only when they change (UploadCache; on the CPU device the kernels read the
    caller's arrays in place, so nothing is copied or compared). The projection writes one 16-byte record
    a vertex (kernels/raster_warp.py), so the triangle pass reads a vertex with one load.

    On the CPU device each thread takes a run of items (kernels/raster_warp.py says why) and the
    positions and the background colour are written through NumPy views of the device buffers; on
    CUDA one thread per item. The four outputs are views of one device buffer that the resolve pass
    only partly rewrites each frame (empty pixels that stay empty keep the background), so a frame
    returns one copy of it: rgb (3n bytes), labels (n), triangle ids (4n), depth (4n) for n pixels.
    """

    CPU_CHUNK = 256          # vertices or triangles per thread on the CPU device (chosen here)

    def __init__(self):
        self._uploads = None
        self._frames = {}

    def _frame(self, s: _Scene, triangles, part, colour, palette, indptr, ids):
        """The buffers and recorded launches for this mesh and image size (built on first use)."""
        V, F, W, H = len(s.positions), len(s.triangles), s.width, s.height
        slot = (V, F, W, H)
        frame = self._frames.get(slot)
        if frame is None:
            from kernels import raster_warp
            wp, device = self._wp, backends.warp_device()
            on_cpu = device == "cpu"
            chunk = self.CPU_CHUNK if on_cpu else 1
            n = W * H
            out = wp.empty(12 * n, dtype=wp.uint8, device=device)
            outputs = [wp.array(ptr=out.ptr + offset, dtype=dtype, shape=(size,), device=device)
                       for offset, size, dtype in ((0, 3 * n, wp.uint8), (3 * n, n, wp.uint8), (4 * n, n, wp.int32),
                                                   (8 * n, n, wp.float32))]
            frame = types.SimpleNamespace(
                positions=wp.empty(V, dtype=wp.vec3, device=device),
                vertices=wp.empty(V, dtype=wp.vec4, device=device),
                normals=wp.zeros(V, dtype=wp.vec3, device=device),
                keys=wp.full(n, int(EMPTY_KEY), dtype=wp.int64, device=device),
                background=wp.zeros(3, dtype=wp.uint8, device=device), out=out, outputs=outputs,
                spans=[wp.full(H, value, dtype=wp.int32, device=device) for value in (W, -1, W, -1)],
                clean=True, fresh=True, on_cpu=on_cpu, settings=None, drawn_background=None)
            if on_cpu:
                frame.positions_host, frame.background_host = frame.positions.numpy(), frame.background.numpy()
                frame.out_host = out.numpy()
            frame.project = wp.launch(raster_warp.project, dim=-(-V // chunk), device=device, record_cmd=True,
                                      inputs=[frame.positions, wp.mat44(), float(W), float(H), chunk, frame.vertices])
            frame.normals_pass = wp.launch(raster_warp.vertex_normals, dim=-(-V // chunk), device=device,
                                           record_cmd=True, inputs=[frame.positions, triangles, indptr, ids, chunk,
                                                                    frame.normals])
            frame.raster = wp.launch(raster_warp.raster, dim=-(-F // chunk), device=device, record_cmd=True,
                                     inputs=[triangles, frame.vertices, W, H, 0, chunk, frame.keys, *frame.spans[:2]])
            frame.resolve = wp.launch(raster_warp.resolve, dim=H, device=device, record_cmd=True,
                                      inputs=[frame.keys, part, palette, frame.background, 0, 1, W, *frame.spans,
                                              *outputs, triangles, frame.vertices, frame.normals, colour, wp.vec3(),
                                              0.0, 0.0])
            frame.inputs = (triangles, part, colour, palette, indptr, ids)
            if len(self._frames) >= 4:
                self._frames.pop(next(iter(self._frames)))
            self._frames[slot] = frame
        return frame

    def render(self, s: _Scene):
        if self._uploads is None:       # Warp and its device, once per renderer (two cached look-ups per frame add up)
            wp, device = backends.warp(), backends.warp_device()
            self._wp = wp
            if device == "cpu":     # the kernels read the caller's arrays in place (no copy, no comparison)
                self._uploads = UploadCache(lambda a: wp.array(a.reshape(-1), device=device, copy=False),
                                            snapshot=False)
            else:
                self._uploads = UploadCache(lambda a: wp.array(a.reshape(-1), device=device))
        wp = self._wp
        W, H = s.width, s.height
        inputs = (self._uploads.get("triangles", s.triangles), self._uploads.get("part", s.triangle_part),
                  self._uploads.get("colour", s.colour), self._uploads.get("palette", s.palette),
                  self._uploads.get("indptr", s.adjacency[0]), self._uploads.get("ids", s.adjacency[1]))
        frame = self._frame(s, *inputs)
        if any(a is not b for a, b in zip(inputs, frame.inputs)):     # the mesh or its colours changed
            frame.raster.set_param_at_index(0, inputs[0])
            frame.normals_pass.set_param_at_index(1, inputs[0])
            frame.normals_pass.set_param_at_index(2, inputs[4])
            frame.normals_pass.set_param_at_index(3, inputs[5])
            frame.resolve.set_param_at_index(1, inputs[1])
            frame.resolve.set_param_at_index(2, inputs[3])
            frame.resolve.set_param_at_index(15, inputs[0])
            frame.resolve.set_param_at_index(18, inputs[2])
            frame.inputs = inputs
        if not frame.clean:            # an earlier frame stopped between raster and resolve
            frame.keys.fill_(int(EMPTY_KEY))
            frame.fresh = True
        background = s.background if s.shaded else s.palette[0]
        settings = (s.camera.tobytes(), s.cull, s.shaded, s.light.tobytes())
        if settings != frame.settings:
            frame.project.set_param_at_index(1, wp.mat44(s.camera))
            frame.raster.set_param_at_index(4, int(s.cull))
            frame.resolve.set_param_at_index(4, int(s.shaded))
            frame.resolve.set_param_at_index(19, wp.vec3(*s.light[:3]))
            frame.resolve.set_param_at_index(20, float(s.light[3]))
            frame.resolve.set_param_at_index(21, float(s.light[4]))
            frame.settings = settings
        if background.tobytes() != frame.drawn_background:
            frame.fresh = True
        if frame.on_cpu:
            frame.positions_host[:] = s.positions
            frame.background_host[:] = background
        else:
            frame.positions.assign(s.positions)
            frame.background.assign(background)
        if frame.fresh:
            frame.resolve.set_param_at_index(5, 1)
        frame.project.launch()
        if s.shaded:
            frame.normals_pass.launch()
        frame.clean = False
        frame.raster.launch()
        frame.resolve.launch()
        frame.clean = True
        if frame.fresh:
            frame.resolve.set_param_at_index(5, 0)
            frame.drawn_background = background.tobytes()
            frame.fresh = False
        # CPU: a copy of the buffer's NumPy view (the next frame overwrites it); CUDA: .numpy() copies already
        host = frame.out_host.copy() if frame.on_cpu else frame.out.numpy()
        n = W * H
        return (host[:3 * n].reshape(H, W, 3), host[3 * n:4 * n].reshape(H, W),
                host[4 * n:8 * n].view(np.int32).reshape(H, W), host[8 * n:12 * n].view(np.float32).reshape(H, W))


# --- OpenCL ---------------------------------------------------------------------------------------
# Chosen here after profiling on PoCL's CPU device (2 threads): one work item per vertex or triangle ran
# the trivial per-item bodies several times slower than a loop over a run of items in one work item, so
# every kernel takes a run (OPENCL_CHUNK vertices or triangles, one image row in the resolve). The other
# costs were the ones of the Warp-CPU path: kernel arguments packed again every frame (now set once per
# mesh and image size), a resolve over every pixel (now only the rows' drawn spans) and the lit colour
# computed per pixel (now per face, in the triangle pass).

_OPENCL_SOURCE = backends.opencl_defines({
    "SUBPIXEL": SUBPIXEL, "HALF_SUBPIXEL": HALF_SUBPIXEL, "MIN_CLIP_W": MIN_CLIP_W, "GUARD_PIXELS": GUARD_PIXELS,
    "DEPTH_SCALE": DEPTH_SCALE, "ID_SCALE": ID_SCALE, "EMPTY_KEY": EMPTY_KEY}) + r"""
#pragma OPENCL FP_CONTRACT OFF
#pragma OPENCL EXTENSION cl_khr_int64_extended_atomics : enable

inline long edge(long ax, long ay, long bx, long by, long px, long py) {
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

inline long top_left_bias(long ax, long ay, long bx, long by) {
    long dx = bx - ax, dy = by - ay;
    return (dy < 0 || (dy == 0 && dx > 0)) ? 0 : 1;
}

/* first pixel whose centre lies at or after fixed-point coordinate low (clipped to 0) */
inline long first_centre(long low) { return (max(low, 0L) + HALF_SUBPIXEL - 1) / SUBPIXEL; }

/* last pixel whose centre lies at or before fixed-point coordinate high, -1 if none */
inline long last_centre(long high) { return high < HALF_SUBPIXEL ? -1L : (high - HALF_SUBPIXEL) / SUBPIXEL; }

/* Vertices [g * chunk, (g + 1) * chunk) of n: the unit sum of the area-weighted normals (p1 - p0) x (p2 - p0) of the
   triangles around each vertex (CSR indptr, ids), in ascending triangle order; zero where the sum is. */
__kernel void vertex_normals(__global const float *positions, __global const int *triangles,
                             __global const int *indptr, __global const int *ids, int n, int chunk,
                             __global float *normals) {
  int first = get_global_id(0) * chunk, last = min(first + chunk, n);
  for (int v = first; v < last; ++v) {
    float x = 0.0f, y = 0.0f, z = 0.0f;
    for (int j = indptr[v]; j < indptr[v + 1]; ++j) {
        int t = ids[j];
        float3 p0 = vload3(triangles[3 * t], positions);
        float3 e1 = vload3(triangles[3 * t + 1], positions) - p0, e2 = vload3(triangles[3 * t + 2], positions) - p0;
        x = x + (e1.y * e2.z - e1.z * e2.y);
        y = y + (e1.z * e2.x - e1.x * e2.z);
        z = z + (e1.x * e2.y - e1.y * e2.x);
    }
    float length = sqrt(x * x + y * y + z * z);
    vstore3(length > 0.0f ? (float3)(x / length, y / length, z / length) : (float3)(0.0f, 0.0f, 0.0f), v, normals);
  }
}

/* Vertices [g * chunk, (g + 1) * chunk) of n. m: the world -> clip matrix, row-major, as one kernel argument.
   not_finite[g]: 1 if any of them has a coordinate that is NaN or infinite, else 0. */
__kernel void project(__global const float *positions, float16 m, float width, float height, int n, int chunk,
                      __global long *fixed_x, __global long *fixed_y, __global float *depth,
                      __global int *valid, __global int *not_finite) {
    int first = get_global_id(0) * chunk, last = min(first + chunk, n), bad = 0;
    for (int v = first; v < last; ++v) {
        float x = positions[3 * v], y = positions[3 * v + 1], z = positions[3 * v + 2];
        /* positions the host did not check (filled on the device): flagged, and their triangles dropped */
        int finite = isfinite(x) && isfinite(y) && isfinite(z);
        bad |= !finite;
        if (!finite) x = y = z = 0.0f;
        float cx = m.s0 * x + m.s1 * y + m.s2 * z + m.s3;
        float cy = m.s4 * x + m.s5 * y + m.s6 * z + m.s7;
        float cz = m.s8 * x + m.s9 * y + m.sa * z + m.sb;
        float cw = m.sc * x + m.sd * y + m.se * z + m.sf;
        int ok = cw > MIN_CLIP_W;
        float w = ok ? cw : 1.0f;
        float wx = (cx / w * 0.5f + 0.5f) * width;
        float wy = (0.5f - cy / w * 0.5f) * height;
        depth[v] = cz / w * 0.5f + 0.5f;
        if (fabs(wx) >= GUARD_PIXELS || fabs(wy) >= GUARD_PIXELS) ok = 0;
        fixed_x[v] = ok ? (long)floor(wx * (float)SUBPIXEL + 0.5f) : 0;
        fixed_y[v] = ok ? (long)floor(wy * (float)SUBPIXEL + 0.5f) : 0;
        valid[v] = ok && finite;
    }
    not_finite[get_global_id(0)] = bad;
}

/* Triangles [g * chunk, (g + 1) * chunk) of n: per-triangle setup, edge functions with the top-left rule over the pixel centres inside the
   bounding box, depth test. Each image row's span of covered pixel centres widens [row_lo, row_hi]. */
__kernel void raster(__global const int *triangles, __global const long *fixed_x, __global const long *fixed_y,
                     __global const float *depth, __global const int *valid, int width, int height, int cull,
                     int n, int chunk, __global long *keys, __global int *row_lo, __global int *row_hi) {
  int first = get_global_id(0) * chunk, last = min(first + chunk, n);
  for (int t = first; t < last; ++t) {
    /* per-triangle setup: drop triangles with a vertex off limits, degenerate ones, culled back faces */
    int i0 = triangles[3 * t], i1 = triangles[3 * t + 1], i2 = triangles[3 * t + 2];
    if (!valid[i0] || !valid[i1] || !valid[i2]) continue;
    long x0 = fixed_x[i0], y0 = fixed_y[i0], x1 = fixed_x[i1], y1 = fixed_y[i1], x2 = fixed_x[i2], y2 = fixed_y[i2];
    long area = edge(x0, y0, x1, y1, x2, y2);
    if (area == 0 || (area > 0 && cull)) continue;
    /* bounding box of the pixel centres the triangle can cover, clipped to the image: a triangle between
       pixel centres (sub-pixel) or off the image covers none and stops here */
    long xmin = first_centre(min(min(x0, x1), x2)), xmax = min(last_centre(max(max(x0, x1), x2)), (long)(width - 1));
    if (xmax < xmin) continue;
    long ymin = first_centre(min(min(y0, y1), y2)), ymax = min(last_centre(max(max(y0, y1), y2)), (long)(height - 1));
    if (ymax < ymin) continue;
    float z0 = depth[i0], z1 = depth[i1], z2 = depth[i2];
    int flipped = 0;
    if (area > 0) {             /* window y points down: front faces turn clockwise, area < 0 */
        /* a back face drawn anyway: orient it clockwise in window space like a front face */
        long tx = x1, ty = y1; float tz = z1;
        x1 = x2; y1 = y2; z1 = z2; x2 = tx; y2 = ty; z2 = tz;
        area = -area;
        flipped = 1;
    }
    /* walking order a, b, c = v0, v2, v1 turns counter-clockwise: edge functions are positive inside */
    long ax = x0, ay = y0, bx = x2, by = y2, cx = x1, cy = y1;
    /* edge functions at the pixel centres, with the top-left rule, stepped incrementally across the box */
    long b0 = top_left_bias(bx, by, cx, cy), b1 = top_left_bias(cx, cy, ax, ay), b2 = top_left_bias(ax, ay, bx, by);
    float inverse_area = 1.0f / (float)(-area);
    float dz1 = z1 - z0, dz2 = z2 - z0;
    long start_x = xmin * SUBPIXEL + HALF_SUBPIXEL, start_y = ymin * SUBPIXEL + HALF_SUBPIXEL;
    /* biased: covered where all three are >= 0, that is where their bitwise or is (one branch, not three) */
    long row0 = edge(bx, by, cx, cy, start_x, start_y) - b0;
    long row1 = edge(cx, cy, ax, ay, start_x, start_y) - b1;
    long row2 = edge(ax, ay, bx, by, start_x, start_y) - b2;
    long step_x0 = -(cy - by) * SUBPIXEL, step_x1 = -(ay - cy) * SUBPIXEL, step_x2 = -(by - ay) * SUBPIXEL;
    long step_y0 = (cx - bx) * SUBPIXEL, step_y1 = (ax - cx) * SUBPIXEL, step_y2 = (bx - ax) * SUBPIXEL;
    for (int py = (int)ymin; py <= (int)ymax; ++py) {
        long e0 = row0, e1 = row1, e2 = row2;
        int run_end = -1;
        for (int px = (int)xmin; px <= (int)xmax; ++px) {
            if ((e0 | e1 | e2) >= 0) {
                if (run_end < 0) atomic_min(&row_lo[py], px);
                run_end = px;
                /* depth test: interpolate, keep [0, 1], atomic minimum of the key depth * ID_SCALE + triangle */
                float l1 = (float)(e2 + b2) * inverse_area;
                float l2 = (float)(e1 + b1) * inverse_area;
                float z = z0 + l1 * dz1 + l2 * dz2;
                if (z >= 0.0f && z <= 1.0f) {
                    long key = (long)(z * DEPTH_SCALE) * ID_SCALE + (long)t;
                    atom_min(&keys[py * width + px], key);
                }
            } else if (run_end >= 0) {
                break;  /* a row's covered pixels are one run (the triangle is convex): none is left */
            }
            e0 += step_x0; e1 += step_x1; e2 += step_x2;
        }
        if (run_end >= 0) atomic_max(&row_hi[py], run_end);
        row0 += step_y0; row1 += step_y1; row2 += step_y2;
    }
  }
}

/* Sets every key to EMPTY_KEY and every row's spans to empty (a new buffer, or a frame stopped mid-way). */
__kernel void clear(__global long *keys, int width, __global int *row_lo, __global int *row_hi) {
    int y = get_global_id(0);
    for (int i = y * width; i < (y + 1) * width; ++i) keys[i] = EMPTY_KEY;
    row_lo[y] = width; row_hi[y] = -1;
}

/* Image row y: each key -> triangle id, label, depth and colour, into one output buffer read back in one
   copy: rgb (3n bytes), labels (n), triangle ids (4n), depth (4n) for n pixels, then one int: whether any
   position was not finite (row 0 gathers the project pass's flags). The key is reset to
   EMPTY_KEY for the next frame. The output is kept from frame to frame: unless `fresh`, only the pixels
   inside this frame's span of covered pixels [row_lo, row_hi] or the last frame's [drawn_lo, drawn_hi] are
   visited (the others were empty then and are empty now, so they hold the background already), and an empty
   pixel that was empty in the last frame (triangle id -1) is not written again. The row's spans then move
   on: drawn = this frame's, this frame's = empty for the next raster pass. */
__kernel void resolve(__global long *keys, __global const uchar *triangle_part,
                      __global const uchar *palette, uchar bg_r, uchar bg_g, uchar bg_b, int shaded, int fresh,
                      int width, int n, __global int *row_lo, __global int *row_hi, __global int *drawn_lo,
                      __global int *drawn_hi, __global uchar *out, __global const int *not_finite, int n_groups,
                      __global const int *triangles, __global const long *fixed_x, __global const long *fixed_y,
                      __global const float *normals, __global const uchar *colour, float lx, float ly, float lz,
                      float ambient, float diffuse) {
    int y = get_global_id(0);
    if (y == 0) {              /* the project pass's flags, gathered into the int after the outputs */
        int any = 0;
        for (int g = 0; g < n_groups; ++g) any |= not_finite[g];
        *(__global int *)(out + 12 * n) = any;
    }
    __global uchar *rgb = out, *labels = out + 3 * n;
    __global int *triangle_id = (__global int *)(out + 4 * n);
    __global float *depth_out = (__global float *)(out + 8 * n);
    int lo = fresh ? 0 : min(row_lo[y], drawn_lo[y]), hi = fresh ? width - 1 : max(row_hi[y], drawn_hi[y]);
    drawn_lo[y] = row_lo[y]; drawn_hi[y] = row_hi[y];
    row_lo[y] = width; row_hi[y] = -1;
    for (int i = y * width + lo; i <= y * width + hi; ++i) {
        long key = keys[i];
        if (key == EMPTY_KEY) {
            if (fresh || triangle_id[i] != -1) {
                labels[i] = 0; triangle_id[i] = -1; depth_out[i] = INFINITY;
                rgb[3 * i] = bg_r; rgb[3 * i + 1] = bg_g; rgb[3 * i + 2] = bg_b;
            }
            continue;
        }
        keys[i] = EMPTY_KEY;
        int t = (int)(key % ID_SCALE);
        uchar label = triangle_part[t];
        labels[i] = label; triangle_id[i] = t;
        depth_out[i] = (float)(key / ID_SCALE) / DEPTH_SCALE;
        if (!shaded) {
            __global const uchar *c = palette + 3 * label;
            rgb[3 * i] = c[0]; rgb[3 * i + 1] = c[1]; rgb[3 * i + 2] = c[2];
            continue;
        }
        /* the vertex normals interpolated at the pixel centre (barycentric weights from the integer edge
           functions), normalised, Lambert; a back face drawn turns its normal round */
        int i0 = triangles[3 * t], i1 = triangles[3 * t + 1], i2 = triangles[3 * t + 2];
        long x0 = fixed_x[i0], y0 = fixed_y[i0], x1 = fixed_x[i1], y1 = fixed_y[i1], x2 = fixed_x[i2], y2 = fixed_y[i2];
        long cx = (long)(i - y * width) * SUBPIXEL + HALF_SUBPIXEL, cy = (long)y * SUBPIXEL + HALF_SUBPIXEL;
        float area = (float)edge(x0, y0, x1, y1, x2, y2);
        float l1 = (float)edge(x2, y2, x0, y0, cx, cy) / area;
        float l2 = (float)edge(x0, y0, x1, y1, cx, cy) / area;
        float3 n0 = vload3(i0, normals), n1 = vload3(i1, normals), n2 = vload3(i2, normals);
        float nx = n0.x + l1 * (n1.x - n0.x) + l2 * (n2.x - n0.x);
        float ny = n0.y + l1 * (n1.y - n0.y) + l2 * (n2.y - n0.y);
        float nz = n0.z + l1 * (n1.z - n0.z) + l2 * (n2.z - n0.z);
        float length = sqrt(nx * nx + ny * ny + nz * nz);
        float cosine = length > 0.0f ? (nx * lx + ny * ly + nz * lz) / length : 0.0f;
        if (area > 0.0f) cosine = -cosine;
        float shade = ambient + diffuse * fmax(cosine, 0.0f);
        for (int k = 0; k < 3; ++k)
            rgb[3 * i + k] = (uchar)fmin((float)colour[3 * t + k] * shade + 0.5f, 255.0f);
    }
}
"""


class _OpenCLRaster:
    """Device buffers and kernels with their arguments set are kept per mesh and image size, so a frame sets
    only what changed (positions upload, camera, light, look, background); the mesh topology, parts and
    colours upload only when they change (UploadCache). A frame is five commands: upload the positions,
    project, raster, resolve (which also clears the keys and spans for the next frame), and one blocking
    read-back of the output buffer that the resolve only partly rewrites (see the kernel)."""

    CHUNK = 64             # vertices or triangles per work item (chosen here, see above)

    def __init__(self):
        self._uploads = None
        self._frames = {}

    def _frame(self, s: _Scene, triangles, part, colour, palette, indptr, ids):
        """The buffers and argument-bound kernels for this mesh and image size (built on first use)."""
        import pyopencl as cl
        context, _ = backends.opencl_queue()
        V, F, W, H = len(s.positions), len(s.triangles), s.width, s.height
        slot = (V, F, W, H)
        frame = self._frames.get(slot)
        if frame is not None:
            return frame
        program = backends.opencl_kernels(_OPENCL_SOURCE).raster.program
        kernels = types.SimpleNamespace(**{name: cl.Kernel(program, name)
                                           for name in ("project", "vertex_normals", "raster", "clear", "resolve")})

        def buffer(nbytes):
            return cl.Buffer(context, cl.mem_flags.READ_WRITE, max(nbytes, 1))

        n, chunk = W * H, self.CHUNK
        frame = types.SimpleNamespace(
            kernels=kernels, positions=buffer(12 * V), fixed_x=buffer(8 * V), fixed_y=buffer(8 * V),
            depth=buffer(4 * V), valid=buffer(4 * V), keys=buffer(8 * n), normals=buffer(12 * V),
            out=buffer(12 * n + 4), spans=[buffer(4 * H) for _ in range(4)], clean=False, fresh=True, settings=None,
            drawn_background=None, inputs=None, project_size=(max(-(-V // chunk), 1),),
            raster_size=(max(-(-F // chunk), 1),))
        frame.not_finite = buffer(4 * frame.project_size[0])
        row_lo, row_hi, drawn_lo, drawn_hi = frame.spans
        kernels.project.set_args(frame.positions, np.zeros(1, cl.cltypes.float16)[0], np.float32(W), np.float32(H),
                                 np.int32(V), np.int32(chunk), frame.fixed_x, frame.fixed_y, frame.depth, frame.valid,
                                 frame.not_finite)
        kernels.vertex_normals.set_args(frame.positions, triangles, indptr, ids, np.int32(V), np.int32(chunk),
                                        frame.normals)
        kernels.raster.set_args(triangles, frame.fixed_x, frame.fixed_y, frame.depth, frame.valid, np.int32(W),
                                np.int32(H), np.int32(0), np.int32(F), np.int32(chunk), frame.keys, row_lo, row_hi)
        kernels.clear.set_args(frame.keys, np.int32(W), row_lo, row_hi)
        kernels.resolve.set_args(frame.keys, part, palette, *np.zeros(3, np.uint8), np.int32(0),
                                 np.int32(1), np.int32(W), np.int32(n), row_lo, row_hi, drawn_lo, drawn_hi, frame.out,
                                 frame.not_finite, np.int32(frame.project_size[0]), triangles, frame.fixed_x,
                                 frame.fixed_y, frame.normals, colour, *np.zeros(5, np.float32))
        frame.inputs = (triangles, part, colour, palette, indptr, ids)
        if len(self._frames) >= 4:
            self._frames.pop(next(iter(self._frames)))
        self._frames[slot] = frame
        return frame

    def render(self, s: _Scene, fill_positions=None):
        """rasterize's outputs; fill_positions: see render_scene (None: upload s.positions)."""
        import pyopencl as cl
        context, queue = backends.opencl_queue()
        if self._uploads is None:
            self._uploads = UploadCache(lambda a: cl.Buffer(context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                                                            hostbuf=np.ascontiguousarray(a)))
        W, H = s.width, s.height
        inputs = (self._uploads.get("triangles", s.triangles), self._uploads.get("part", s.triangle_part),
                  self._uploads.get("colour", s.colour), self._uploads.get("palette", s.palette),
                  self._uploads.get("indptr", s.adjacency[0]), self._uploads.get("ids", s.adjacency[1]))
        frame = self._frame(s, *inputs)
        k = frame.kernels
        if any(a is not b for a, b in zip(inputs, frame.inputs)):     # the mesh or its colours changed
            k.raster.set_arg(0, inputs[0])
            k.vertex_normals.set_arg(1, inputs[0])
            k.vertex_normals.set_arg(2, inputs[4])
            k.vertex_normals.set_arg(3, inputs[5])
            k.resolve.set_arg(1, inputs[1])
            k.resolve.set_arg(2, inputs[3])
            k.resolve.set_arg(17, inputs[0])
            k.resolve.set_arg(21, inputs[2])
            frame.inputs = inputs
        if not frame.clean:            # a new buffer, or an earlier frame stopped between raster and resolve
            k.clear.set_args(frame.keys, np.int32(W), *frame.spans[:2])
            cl.enqueue_nd_range_kernel(queue, k.clear, (H,), None)
            frame.fresh = True
        settings = (s.camera.tobytes(), s.cull, s.shaded, s.light.tobytes())
        if settings != frame.settings:
            camera = np.zeros(1, cl.cltypes.float16)
            camera.view(np.float32)[:] = s.camera.reshape(-1)
            k.project.set_arg(1, camera[0])
            k.raster.set_arg(7, np.int32(s.cull))
            for index, value in enumerate(s.light):
                k.resolve.set_arg(22 + index, np.float32(value))
            k.resolve.set_arg(6, np.int32(s.shaded))
            frame.settings = settings
        background = s.background if s.shaded else s.palette[0]
        if frame.drawn_background != background.tobytes():
            for index, value in enumerate(background):
                k.resolve.set_arg(3 + index, np.uint8(value))
            frame.fresh = True
        if frame.fresh:
            k.resolve.set_arg(7, np.int32(1))
        if fill_positions is None:
            cl.enqueue_copy(queue, frame.positions, s.positions, is_blocking=False)
        else:
            fill_positions(queue, frame.positions)
        cl.enqueue_nd_range_kernel(queue, k.project, frame.project_size, None)
        if s.shaded:
            cl.enqueue_nd_range_kernel(queue, k.vertex_normals, frame.project_size, None)
        frame.clean = False
        cl.enqueue_nd_range_kernel(queue, k.raster, frame.raster_size, None)
        cl.enqueue_nd_range_kernel(queue, k.resolve, (H,), None)
        n = W * H
        host = np.empty(12 * n + 4, np.uint8)
        cl.enqueue_copy(queue, host, frame.out, is_blocking=True)
        frame.clean = True
        if frame.fresh:
            k.resolve.set_arg(7, np.int32(0))
            frame.drawn_background = background.tobytes()
            frame.fresh = False
        if host[12 * n:].any():          # only positions filled on the device can get here (rasterize checks)
            raise KernelError(NOT_FINITE)
        return (host[:3 * n].reshape(H, W, 3), host[3 * n:4 * n].reshape(H, W),
                host[4 * n:8 * n].view(np.int32).reshape(H, W), host[8 * n:12 * n].view(np.float32).reshape(H, W))


_IMPLEMENTATIONS = {"numpy": _NumpyRaster(), "warp": _WarpRaster(), "opencl": _OpenCLRaster()}
