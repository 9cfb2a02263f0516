"""Triangle rasterizer: z-buffer, per-pixel part label and triangle id, two looks.

One entry point, `rasterize`, with three bodies that follow the same steps and the same arithmetic:

1. project: each vertex to window coordinates, snapped to 1/256 pixel (integers), and depth in [0, 1];
2. raster: one thread per triangle culls back faces, lights the face (shaded look: Lambert of its
   normal, ambient + key * max(n . l, 0)) and walks its bounding box; coverage is decided with
   exact integer edge functions at pixel centres and the top-left fill rule, so neighbouring
   triangles never share or miss a pixel and every backend covers the same pixels. Each covered
   pixel takes an atomic minimum of a 64-bit key `depth * 2^32 + triangle`, so depth ties resolve
   to the lower triangle id whatever the thread order (one pass, deterministic);
3. resolve: each pixel decodes its key into triangle id, label, depth and colour.

At the default sizes a triangle of the avatar covers a few pixels, so per-face lighting is as
smooth as interpolated normals would be, and costs no per-vertex normal pass.

Looks: "shaded" (Lambert per face on a per-triangle albedo, uniform background) and
"flat" (seed 000 §4.2.2's modified appearance: one uniform colour per part, no light, so masks can
be read back by colour). Labels are always hard (no anti-aliasing).
"""

import functools

import numpy as np

from kernels import backends
from kernels._arrays import UploadCache, as_array, check_indices
from kernels.errors import KernelError

LOOKS = ("shaded", "flat")
SUBPIXEL = 256                         # fixed-point steps per pixel
EMPTY_KEY = np.int64(2**63 - 1)        # no triangle covers the pixel
DEPTH_SCALE = np.float32(2**31)        # depth in [0, 1] -> 31-bit integer in the key's high word
ID_SCALE = np.int64(2**32)
GUARD_PIXELS = np.float32(32768.0)     # vertices farther off-screen than this drop their triangles

# Colours are indexed by part label (0 background, 1 body/clothes, 2 head, 3 left hand, 4 right hand).
FLAT_PALETTE = np.array([[0, 0, 0], [0, 0, 255], [255, 0, 0], [0, 255, 0], [255, 255, 0]], dtype=np.uint8)
SHADED_ALBEDO = np.array([[0, 0, 0], [46, 52, 70], [226, 176, 146], [226, 176, 146], [226, 176, 146]], dtype=np.uint8)
STUDIO_BACKGROUND = np.array([92, 112, 128], dtype=np.uint8)
KEY_LIGHT = np.array([0.35, 0.45, 1.0])            # direction towards the light, world (avatar faces +Z)
AMBIENT, DIFFUSE = 0.30, 0.75


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
    if look not in LOOKS:
        raise KernelError(f"unknown look {look!r}: choose shaded or flat")
    if not (isinstance(width, (int, np.integer)) and isinstance(height, (int, np.integer))
            and 1 <= width <= 8192 and 1 <= height <= 8192):
        raise KernelError(f"image size must be whole pixels in [1, 8192], got {width}x{height}")
    positions = as_array("positions", positions, np.float32, (None, 3))
    triangles = as_array("triangles", triangles, np.int32, (None, 3))
    triangle_part = as_array("triangle_part", triangle_part, np.uint8, (len(triangles),))
    camera = as_array("camera", camera, np.float32, (4, 4))
    check_indices("triangles", triangles, len(positions))
    if not np.all(np.isfinite(positions)):
        raise KernelError("positions hold NaN or infinite values")
    palette = as_array("palette", FLAT_PALETTE if palette is None else palette, np.uint8, (None, 3))
    check_indices("triangle_part", triangle_part, len(palette))
    if look == "shaded":
        colour = SHADED_ALBEDO[np.minimum(triangle_part, len(SHADED_ALBEDO) - 1)] if triangle_colour is None else triangle_colour
        colour = as_array("triangle_colour", colour, np.uint8, (len(triangles), 3))
        background = as_array("background", STUDIO_BACKGROUND if background is None else background, np.uint8, (3,))
    else:
        colour = np.zeros((len(triangles), 3), np.uint8)
        background = palette[0].copy()
    light = np.array([*(KEY_LIGHT / np.linalg.norm(KEY_LIGHT)), AMBIENT, DIFFUSE], dtype=np.float32)
    scene = _Scene(positions, triangles, triangle_part, camera, int(width), int(height), look == "shaded",
                   colour, palette, background, light, bool(cull_back_faces))
    return _IMPLEMENTATIONS[backends.resolve(backend)].render(scene)


class _Scene:
    """Checked arguments of one rasterize call."""

    def __init__(self, positions, triangles, triangle_part, camera, width, height, shaded, colour, palette,
                 background, light, cull):
        self.positions, self.triangles, self.triangle_part, self.camera = positions, triangles, triangle_part, camera
        self.width, self.height, self.shaded = width, height, shaded
        self.colour, self.palette, self.background, self.light, self.cull = colour, palette, background, light, cull


# --- NumPy: the oracle ----------------------------------------------------------------------------

def _project_numpy(positions, camera, width, height):
    """Window coordinates in 1/256 pixel (int64), depth (float32), validity; float32 throughout."""
    x, y, z = positions[:, 0], positions[:, 1], positions[:, 2]
    m = camera
    clip = [m[r, 0] * x + m[r, 1] * y + m[r, 2] * z + m[r, 3] for r in range(4)]
    w = clip[3]
    valid = w > np.float32(1e-6)
    safe_w = np.where(valid, w, np.float32(1))
    half = np.float32(0.5)
    window_x = (clip[0] / safe_w * half + half) * np.float32(width)
    window_y = (half - clip[1] / safe_w * half) * np.float32(height)
    depth = clip[2] / safe_w * half + half
    valid &= (np.abs(window_x) < GUARD_PIXELS) & (np.abs(window_y) < GUARD_PIXELS)
    sub = np.float32(SUBPIXEL)
    fixed_x = np.where(valid, np.floor(window_x * sub + half), 0).astype(np.int64)
    fixed_y = np.where(valid, np.floor(window_y * sub + half), 0).astype(np.int64)
    return fixed_x, fixed_y, depth.astype(np.float32), valid


def _edge(ax, ay, bx, by, px, py):
    """Integer edge function of edge a->b at p: positive on the inner side of a positive-area triangle."""
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


def _top_left_bias(ax, ay, bx, by):
    """0 where pixels exactly on the edge belong to the triangle (top or left edge), else 1."""
    dx, dy = bx - ax, by - ay
    return np.where((dy < 0) | ((dy == 0) & (dx > 0)), 0, 1)


def _face_shade_numpy(positions, triangles, flipped, light):
    """(F,) float32 Lambert factor of each face, ambient + diffuse * max(n . l, 0), float32 throughout."""
    p0, p1, p2 = (positions[triangles[:, k]] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    nx = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
    ny = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
    nz = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    length = np.sqrt(nx * nx + ny * ny + nz * nz)
    towards = nx * light[0] + ny * light[1] + nz * light[2]
    cosine = np.where(length > 0, towards / np.where(length > 0, length, np.float32(1)), np.float32(0))
    cosine = np.where(flipped, -cosine, cosine)
    return (light[3] + light[4] * np.maximum(cosine, np.float32(0))).astype(np.float32)


class _NumpyRaster:
    def render(self, s: _Scene):
        W, H = s.width, s.height
        fx, fy, depth, valid = _project_numpy(s.positions, s.camera, W, H)
        tri = s.triangles
        i0, i1, i2 = tri[:, 0], tri[:, 1], tri[:, 2]
        x0, y0, x1, y1, x2, y2 = fx[i0], fy[i0], fx[i1], fy[i1], fx[i2], fy[i2]
        area = _edge(x0, y0, x1, y1, x2, y2)
        keep = valid[i0] & valid[i1] & valid[i2] & (area != 0)
        if s.cull:
            keep &= area < 0                    # window y points down: front faces turn clockwise
        flip = area > 0                        # orient every kept triangle to negative area, then negate
        x1, x2 = np.where(flip, x2, x1), np.where(flip, x1, x2)
        y1, y2 = np.where(flip, y2, y1), np.where(flip, y1, y2)
        z0, z1, z2 = depth[i0], np.where(flip, depth[i2], depth[i1]), np.where(flip, depth[i1], depth[i2])
        area = -np.abs(area)
        xmin = np.maximum(np.minimum(np.minimum(x0, x1), x2), 0) // SUBPIXEL
        xmax = np.minimum(np.maximum(np.maximum(x0, x1), x2) // SUBPIXEL, W - 1)
        ymin = np.maximum(np.minimum(np.minimum(y0, y1), y2), 0) // SUBPIXEL
        ymax = np.minimum(np.maximum(np.maximum(y0, y1), y2) // SUBPIXEL, H - 1)
        keep &= (xmax >= xmin) & (ymax >= ymin)
        ids = np.flatnonzero(keep)
        span_x = (xmax - xmin + 1)[ids]
        counts = span_x * (ymax - ymin + 1)[ids]
        t = np.repeat(ids, counts)
        offset = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        px = xmin[t] + offset % span_x.repeat(counts)
        py = ymin[t] + offset // span_x.repeat(counts)
        cx, cy = px * SUBPIXEL + SUBPIXEL // 2, py * SUBPIXEL + SUBPIXEL // 2
        # After the flip the triangle turns clockwise in window space (area < 0), so swap the walking
        # order (v0, v2, v1) to get positive edge functions inside.
        X0, Y0, X1, Y1, X2, Y2 = x0[t], y0[t], x2[t], y2[t], x1[t], y1[t]
        w0 = _edge(X1, Y1, X2, Y2, cx, cy) - _top_left_bias(X1, Y1, X2, Y2)
        w1 = _edge(X2, Y2, X0, Y0, cx, cy) - _top_left_bias(X2, Y2, X0, Y0)
        w2 = _edge(X0, Y0, X1, Y1, cx, cy) - _top_left_bias(X0, Y0, X1, Y1)
        inside = (w0 >= 0) & (w1 >= 0) & (w2 >= 0)
        t, px, py = t[inside], px[inside], py[inside]
        e1 = _edge(X2, Y2, X0, Y0, cx, cy)[inside]      # weight of the walking order's v1 = original v2
        e2 = _edge(X0, Y0, X1, Y1, cx, cy)[inside]      # weight of the walking order's v2 = original v1
        inverse_area = np.float32(1) / (-area[t]).astype(np.float32)
        l1, l2 = e2.astype(np.float32) * inverse_area, e1.astype(np.float32) * inverse_area
        z = z0[t] + l1 * (z1[t] - z0[t]) + l2 * (z2[t] - z0[t])
        in_range = (z >= 0) & (z <= 1)
        t, px, py, z = t[in_range], px[in_range], py[in_range], z[in_range]
        key = (z * DEPTH_SCALE).astype(np.int64) * ID_SCALE + t
        keys = np.full(W * H, EMPTY_KEY, dtype=np.int64)
        np.minimum.at(keys, py * W + px, key)
        shade = _face_shade_numpy(s.positions, s.triangles, flip, s.light) if s.shaded else None
        return self._resolve(s, keys, shade)

    @staticmethod
    def _resolve(s, keys, shade):
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
            value = s.colour[t].astype(np.float32) * shade[t][:, None] + np.float32(0.5)
            rgb[pixel] = np.minimum(value, np.float32(255)).astype(np.uint8)
        return (rgb.reshape(H, W, 3), labels.reshape(H, W), triangle_id.reshape(H, W), depth.reshape(H, W))


# --- Warp -----------------------------------------------------------------------------------------

@functools.cache
def _warp_kernels():
    wp = backends.warp()
    SUB = wp.constant(wp.int64(SUBPIXEL))
    HALF_SUB = wp.constant(wp.int64(SUBPIXEL // 2))
    EMPTY = wp.constant(wp.int64(int(EMPTY_KEY)))
    KEY_SCALE = wp.constant(wp.int64(int(ID_SCALE)))

    @wp.func
    def edge(ax: wp.int64, ay: wp.int64, bx: wp.int64, by: wp.int64, px: wp.int64, py: wp.int64):
        return (bx - ax) * (py - ay) - (by - ay) * (px - ax)

    @wp.func
    def top_left_bias(ax: wp.int64, ay: wp.int64, bx: wp.int64, by: wp.int64):
        dx = bx - ax
        dy = by - ay
        if dy < wp.int64(0) or (dy == wp.int64(0) and dx > wp.int64(0)):
            return wp.int64(0)
        return wp.int64(1)

    @wp.func
    def face_shade(p0: wp.vec3, p1: wp.vec3, p2: wp.vec3, flipped: wp.int32, light: wp.vec3,
                   ambient: wp.float32, diffuse: wp.float32):
        e1 = p1 - p0
        e2 = p2 - p0
        nx = e1[1] * e2[2] - e1[2] * e2[1]
        ny = e1[2] * e2[0] - e1[0] * e2[2]
        nz = e1[0] * e2[1] - e1[1] * e2[0]
        length = wp.sqrt(nx * nx + ny * ny + nz * nz)
        cosine = float(0.0)
        if length > 0.0:
            cosine = (nx * light[0] + ny * light[1] + nz * light[2]) / length
        if flipped != 0:
            cosine = -cosine
        return ambient + diffuse * wp.max(cosine, 0.0)

    @wp.kernel
    def project(positions: wp.array(dtype=wp.vec3), m: wp.mat44, width: wp.float32, height: wp.float32,
                fixed_x: wp.array(dtype=wp.int64), fixed_y: wp.array(dtype=wp.int64),
                depth: wp.array(dtype=wp.float32), valid: wp.array(dtype=wp.int32)):
        v = wp.tid()
        p = positions[v]
        cx = m[0, 0] * p[0] + m[0, 1] * p[1] + m[0, 2] * p[2] + m[0, 3]
        cy = m[1, 0] * p[0] + m[1, 1] * p[1] + m[1, 2] * p[2] + m[1, 3]
        cz = m[2, 0] * p[0] + m[2, 1] * p[1] + m[2, 2] * p[2] + m[2, 3]
        cw = m[3, 0] * p[0] + m[3, 1] * p[1] + m[3, 2] * p[2] + m[3, 3]
        ok = cw > 1.0e-6
        w = 1.0
        if ok:
            w = cw
        wx = (cx / w * 0.5 + 0.5) * width
        wy = (0.5 - cy / w * 0.5) * height
        depth[v] = cz / w * 0.5 + 0.5
        if wp.abs(wx) >= 32768.0 or wp.abs(wy) >= 32768.0:
            ok = False
        if ok:
            fixed_x[v] = wp.int64(wp.floor(wx * 256.0 + 0.5))
            fixed_y[v] = wp.int64(wp.floor(wy * 256.0 + 0.5))
            valid[v] = 1
        else:
            fixed_x[v] = wp.int64(0)
            fixed_y[v] = wp.int64(0)
            valid[v] = 0

    @wp.kernel
    def raster(triangles: wp.array(dtype=wp.int32), positions: wp.array(dtype=wp.vec3),
               fixed_x: wp.array(dtype=wp.int64), fixed_y: wp.array(dtype=wp.int64),
               depth: wp.array(dtype=wp.float32), valid: wp.array(dtype=wp.int32), width: wp.int32,
               height: wp.int32, cull: wp.int32, shaded: wp.int32, light: wp.vec3, ambient: wp.float32,
               diffuse: wp.float32, keys: wp.array(dtype=wp.int64), shade: wp.array(dtype=wp.float32)):
        t = wp.tid()
        i0 = triangles[3 * t]
        i1 = triangles[3 * t + 1]
        i2 = triangles[3 * t + 2]
        if valid[i0] == 0 or valid[i1] == 0 or valid[i2] == 0:
            return
        x0 = fixed_x[i0]
        y0 = fixed_y[i0]
        x1 = fixed_x[i1]
        y1 = fixed_y[i1]
        x2 = fixed_x[i2]
        y2 = fixed_y[i2]
        z0 = depth[i0]
        z1 = depth[i1]
        z2 = depth[i2]
        area = edge(x0, y0, x1, y1, x2, y2)
        if area == wp.int64(0):
            return
        flipped = int(0)
        if area > wp.int64(0):
            if cull != 0:
                return
            # a back face drawn anyway: orient it clockwise in window space like a front face
            x1 = fixed_x[i2]
            y1 = fixed_y[i2]
            x2 = fixed_x[i1]
            y2 = fixed_y[i1]
            z1 = depth[i2]
            z2 = depth[i1]
            area = -area
            flipped = 1
        if wp.max(wp.max(x0, x1), x2) < wp.int64(0) or wp.max(wp.max(y0, y1), y2) < wp.int64(0):
            return
        xmin = wp.max(wp.min(wp.min(x0, x1), x2), wp.int64(0)) / SUB
        xmax = wp.min(wp.max(wp.max(x0, x1), x2) / SUB, wp.int64(width - 1))
        ymin = wp.max(wp.min(wp.min(y0, y1), y2), wp.int64(0)) / SUB
        ymax = wp.min(wp.max(wp.max(y0, y1), y2) / SUB, wp.int64(height - 1))
        if xmax < xmin or ymax < ymin:
            return
        if shaded != 0:
            shade[t] = face_shade(positions[i0], positions[i1], positions[i2], flipped, light, ambient, diffuse)
        # walking order a, b, c = v0, v2, v1 turns counter-clockwise: edge functions are positive inside
        ax = x0
        ay = y0
        bx = x2
        by = y2
        cx = x1
        cy = y1
        b0 = top_left_bias(bx, by, cx, cy)
        b1 = top_left_bias(cx, cy, ax, ay)
        b2 = top_left_bias(ax, ay, bx, by)
        inverse_area = 1.0 / wp.float32(-area)
        dz1 = z1 - z0
        dz2 = z2 - z0
        start_x = xmin * SUB + HALF_SUB
        start_y = ymin * SUB + HALF_SUB
        row0 = edge(bx, by, cx, cy, start_x, start_y)
        row1 = edge(cx, cy, ax, ay, start_x, start_y)
        row2 = edge(ax, ay, bx, by, start_x, start_y)
        step_x0 = -(cy - by) * SUB
        step_x1 = -(ay - cy) * SUB
        step_x2 = -(by - ay) * SUB
        step_y0 = (cx - bx) * SUB
        step_y1 = (ax - cx) * SUB
        step_y2 = (bx - ax) * SUB
        for py in range(wp.int32(ymin), wp.int32(ymax) + 1):
            e0 = row0
            e1 = row1
            e2 = row2
            for px in range(wp.int32(xmin), wp.int32(xmax) + 1):
                if e0 >= b0 and e1 >= b1 and e2 >= b2:
                    l1 = wp.float32(e2) * inverse_area
                    l2 = wp.float32(e1) * inverse_area
                    z = z0 + l1 * dz1 + l2 * dz2
                    if z >= 0.0 and z <= 1.0:
                        key = wp.int64(z * 2147483648.0) * KEY_SCALE + wp.int64(t)
                        wp.atomic_min(keys, py * width + px, key)
                e0 += step_x0
                e1 += step_x1
                e2 += step_x2
            row0 += step_y0
            row1 += step_y1
            row2 += step_y2

    @wp.kernel
    def resolve(keys: wp.array(dtype=wp.int64), triangle_part: wp.array(dtype=wp.uint8),
                shade: wp.array(dtype=wp.float32), colour: wp.array(dtype=wp.uint8),
                palette: wp.array(dtype=wp.uint8), background: wp.array(dtype=wp.uint8), shaded: wp.int32,
                rgb: wp.array(dtype=wp.uint8), labels: wp.array(dtype=wp.uint8),
                triangle_id: wp.array(dtype=wp.int32), depth_out: wp.array(dtype=wp.float32)):
        i = wp.tid()
        key = keys[i]
        if key == EMPTY:
            labels[i] = wp.uint8(0)
            triangle_id[i] = -1
            depth_out[i] = wp.inf
            for k in range(3):
                rgb[3 * i + k] = background[k]
            return
        t = wp.int32(key % KEY_SCALE)
        label = triangle_part[t]
        labels[i] = label
        triangle_id[i] = t
        depth_out[i] = wp.float32(key / KEY_SCALE) / 2147483648.0
        if shaded == 0:
            for k in range(3):
                rgb[3 * i + k] = palette[3 * wp.int32(label) + k]
        else:
            s = shade[t]
            for k in range(3):
                rgb[3 * i + k] = wp.uint8(wp.min(wp.float32(colour[3 * t + k]) * s + 0.5, 255.0))

    return project, raster, resolve


class _WarpRaster:
    """Device buffers are allocated once per image and mesh size; the mesh topology uploads once.
    On the CPU device the outputs are fresh NumPy arrays that the kernels write into directly."""

    def __init__(self):
        self._uploads = None
        self._buffers = {}

    def _buffer(self, name, n, dtype):
        wp, device = backends.warp(), backends.warp_device()
        slot = (name, n)
        if slot not in self._buffers:
            self._buffers[slot] = wp.empty(n, dtype=dtype, device=device)
        return self._buffers[slot]

    def render(self, s: _Scene):
        wp, device = backends.warp(), backends.warp_device()
        project, raster, resolve = _warp_kernels()
        if self._uploads is None:
            self._uploads = UploadCache(lambda a: wp.array(a.reshape(-1), device=device))
        V, F, W, H = len(s.positions), len(s.triangles), s.width, s.height
        on_cpu = device == "cpu"
        positions = wp.array(s.positions, dtype=wp.vec3, device=device, copy=not on_cpu)
        triangles = self._uploads.get("triangles", s.triangles)
        fixed_x, fixed_y = self._buffer("fixed_x", V, wp.int64), self._buffer("fixed_y", V, wp.int64)
        depth, valid = self._buffer("depth", V, wp.float32), self._buffer("valid", V, wp.int32)
        wp.launch(project, dim=V, device=device,
                  inputs=[positions, wp.mat44(s.camera), float(W), float(H), fixed_x, fixed_y, depth, valid])
        keys = self._buffer("keys", W * H, wp.int64)
        keys.fill_(int(EMPTY_KEY))
        shade = self._buffer("shade", F, wp.float32)
        wp.launch(raster, dim=F, device=device,
                  inputs=[triangles, positions, fixed_x, fixed_y, depth, valid, W, H, int(s.cull), int(s.shaded),
                          wp.vec3(*s.light[:3]), float(s.light[3]), float(s.light[4]), keys, shade])
        host = (np.empty((H, W, 3), np.uint8), np.empty((H, W), np.uint8), np.empty((H, W), np.int32),
                np.empty((H, W), np.float32))
        if on_cpu:
            outputs = [wp.array(a.reshape(-1), device=device, copy=False) for a in host]
        else:
            outputs = [self._buffer(name, a.size, dtype) for name, a, dtype in
                       zip(("rgb", "labels", "triangle_id", "depth_out"), host, (wp.uint8, wp.uint8, wp.int32, wp.float32))]
        background = s.background if s.shaded else s.palette[0]
        wp.launch(resolve, dim=W * H, device=device,
                  inputs=[keys, self._uploads.get("part", s.triangle_part), shade, self._uploads.get("colour", s.colour),
                          self._uploads.get("palette", s.palette), wp.array(background, device=device),
                          int(s.shaded), *outputs])
        if on_cpu:
            return host
        return tuple(o.numpy().reshape(a.shape) for o, a in zip(outputs, host))


# --- OpenCL ---------------------------------------------------------------------------------------

_OPENCL_SOURCE = r"""
#pragma OPENCL FP_CONTRACT OFF
#pragma OPENCL EXTENSION cl_khr_int64_extended_atomics : enable
#define SUB 256L
#define HALF_SUB 128L
#define EMPTY 0x7fffffffffffffffL
#define KEY_SCALE 4294967296L

inline long edge(long ax, long ay, long bx, long by, long px, long py) {
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

inline long top_left_bias(long ax, long ay, long bx, long by) {
    long dx = bx - ax, dy = by - ay;
    return (dy < 0 || (dy == 0 && dx > 0)) ? 0 : 1;
}

inline float face_shade(float3 p0, float3 p1, float3 p2, int flipped, float lx, float ly, float lz,
                        float ambient, float diffuse) {
    float3 e1 = p1 - p0, e2 = p2 - p0;
    float nx = e1.y * e2.z - e1.z * e2.y;
    float ny = e1.z * e2.x - e1.x * e2.z;
    float nz = e1.x * e2.y - e1.y * e2.x;
    float length = sqrt(nx * nx + ny * ny + nz * nz);
    float cosine = length > 0.0f ? (nx * lx + ny * ly + nz * lz) / length : 0.0f;
    if (flipped) cosine = -cosine;
    return ambient + diffuse * fmax(cosine, 0.0f);
}

__kernel void project(__global const float *positions, __constant float *m, float width, float height,
                      __global long *fixed_x, __global long *fixed_y, __global float *depth,
                      __global int *valid) {
    int v = get_global_id(0);
    float x = positions[3 * v], y = positions[3 * v + 1], z = positions[3 * v + 2];
    float cx = m[0] * x + m[1] * y + m[2] * z + m[3];
    float cy = m[4] * x + m[5] * y + m[6] * z + m[7];
    float cz = m[8] * x + m[9] * y + m[10] * z + m[11];
    float cw = m[12] * x + m[13] * y + m[14] * z + m[15];
    int ok = cw > 1.0e-6f;
    float w = ok ? cw : 1.0f;
    float wx = (cx / w * 0.5f + 0.5f) * width;
    float wy = (0.5f - cy / w * 0.5f) * height;
    depth[v] = cz / w * 0.5f + 0.5f;
    if (fabs(wx) >= 32768.0f || fabs(wy) >= 32768.0f) ok = 0;
    fixed_x[v] = ok ? (long)floor(wx * 256.0f + 0.5f) : 0;
    fixed_y[v] = ok ? (long)floor(wy * 256.0f + 0.5f) : 0;
    valid[v] = ok;
}

__kernel void raster(__global const int *triangles, __global const float *positions,
                     __global const long *fixed_x, __global const long *fixed_y,
                     __global const float *depth, __global const int *valid, int width, int height, int cull,
                     int shaded, float lx, float ly, float lz, float ambient, float diffuse,
                     __global long *keys, __global float *shade) {
    int t = get_global_id(0);
    int i0 = triangles[3 * t], i1 = triangles[3 * t + 1], i2 = triangles[3 * t + 2];
    if (!valid[i0] || !valid[i1] || !valid[i2]) return;
    long x0 = fixed_x[i0], y0 = fixed_y[i0], x1 = fixed_x[i1], y1 = fixed_y[i1], x2 = fixed_x[i2], y2 = fixed_y[i2];
    float z0 = depth[i0], z1 = depth[i1], z2 = depth[i2];
    long area = edge(x0, y0, x1, y1, x2, y2);
    if (area == 0) return;
    int flipped = 0;
    if (area > 0) {
        if (cull) return;
        /* a back face drawn anyway: orient it clockwise in window space like a front face */
        long tx = x1, ty = y1; float tz = z1;
        x1 = x2; y1 = y2; z1 = z2; x2 = tx; y2 = ty; z2 = tz;
        area = -area;
        flipped = 1;
    }
    if (max(max(x0, x1), x2) < 0 || max(max(y0, y1), y2) < 0) return;
    long xmin = max(min(min(x0, x1), x2), 0L) / SUB, xmax = min(max(max(x0, x1), x2) / SUB, (long)(width - 1));
    long ymin = max(min(min(y0, y1), y2), 0L) / SUB, ymax = min(max(max(y0, y1), y2) / SUB, (long)(height - 1));
    if (xmax < xmin || ymax < ymin) return;
    if (shaded)
        shade[t] = face_shade(vload3(i0, positions), vload3(i1, positions), vload3(i2, positions), flipped,
                              lx, ly, lz, ambient, diffuse);
    /* walking order a, b, c = v0, v2, v1 turns counter-clockwise: edge functions are positive inside */
    long ax = x0, ay = y0, bx = x2, by = y2, cx = x1, cy = y1;
    long b0 = top_left_bias(bx, by, cx, cy), b1 = top_left_bias(cx, cy, ax, ay), b2 = top_left_bias(ax, ay, bx, by);
    float inverse_area = 1.0f / (float)(-area);
    float dz1 = z1 - z0, dz2 = z2 - z0;
    long start_x = xmin * SUB + HALF_SUB, start_y = ymin * SUB + HALF_SUB;
    long row0 = edge(bx, by, cx, cy, start_x, start_y);
    long row1 = edge(cx, cy, ax, ay, start_x, start_y);
    long row2 = edge(ax, ay, bx, by, start_x, start_y);
    long step_x0 = -(cy - by) * SUB, step_x1 = -(ay - cy) * SUB, step_x2 = -(by - ay) * SUB;
    long step_y0 = (cx - bx) * SUB, step_y1 = (ax - cx) * SUB, step_y2 = (bx - ax) * SUB;
    for (int py = (int)ymin; py <= (int)ymax; ++py) {
        long e0 = row0, e1 = row1, e2 = row2;
        for (int px = (int)xmin; px <= (int)xmax; ++px) {
            if (e0 >= b0 && e1 >= b1 && e2 >= b2) {
                float l1 = (float)e2 * inverse_area;
                float l2 = (float)e1 * inverse_area;
                float z = z0 + l1 * dz1 + l2 * dz2;
                if (z >= 0.0f && z <= 1.0f) {
                    long key = (long)(z * 2147483648.0f) * KEY_SCALE + (long)t;
                    atom_min(&keys[py * width + px], key);
                }
            }
            e0 += step_x0; e1 += step_x1; e2 += step_x2;
        }
        row0 += step_y0; row1 += step_y1; row2 += step_y2;
    }
}

__kernel void clear(__global long *keys) { keys[get_global_id(0)] = EMPTY; }

__kernel void resolve(__global const long *keys, __global const uchar *triangle_part, __global const float *shade,
                      __global const uchar *colour, __global const uchar *palette, uchar bg_r, uchar bg_g,
                      uchar bg_b, int shaded, __global uchar *rgb, __global uchar *labels,
                      __global int *triangle_id, __global float *depth_out) {
    int i = get_global_id(0);
    long key = keys[i];
    if (key == EMPTY) {
        labels[i] = 0; triangle_id[i] = -1; depth_out[i] = INFINITY;
        rgb[3 * i] = bg_r; rgb[3 * i + 1] = bg_g; rgb[3 * i + 2] = bg_b;
        return;
    }
    int t = (int)(key % KEY_SCALE);
    uchar label = triangle_part[t];
    labels[i] = label; triangle_id[i] = t;
    depth_out[i] = (float)(key / KEY_SCALE) / 2147483648.0f;
    if (!shaded) {
        for (int k = 0; k < 3; ++k) rgb[3 * i + k] = palette[3 * label + k];
    } else {
        float s = shade[t];
        for (int k = 0; k < 3; ++k) rgb[3 * i + k] = (uchar)fmin((float)colour[3 * t + k] * s + 0.5f, 255.0f);
    }
}
"""


class _OpenCLRaster:
    """One program, kernels fetched once, device buffers kept per size; topology uploads once."""

    def __init__(self):
        self._uploads = None
        self._buffers = {}
        self._kernels = None

    def _buffer(self, name, nbytes):
        import pyopencl as cl
        context, _ = backends.opencl_queue()
        if self._buffers.get(name, (None, -1))[1] != nbytes:
            self._buffers[name] = (cl.Buffer(context, cl.mem_flags.READ_WRITE, nbytes), nbytes)
        return self._buffers[name][0]

    def render(self, s: _Scene):
        import pyopencl as cl
        context, queue = backends.opencl_queue()
        if self._kernels is None:
            program = backends.opencl_program(_OPENCL_SOURCE)
            self._kernels = {name: getattr(program, name) for name in ("project", "raster", "clear", "resolve")}
            self._uploads = UploadCache(lambda a: cl.Buffer(context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                                                            hostbuf=np.ascontiguousarray(a)))
        k = self._kernels
        V, F, W, H = len(s.positions), len(s.triangles), s.width, s.height
        positions = self._buffer("positions", s.positions.nbytes)
        cl.enqueue_copy(queue, positions, s.positions, is_blocking=False)
        camera = self._buffer("camera", 64)
        cl.enqueue_copy(queue, camera, s.camera, is_blocking=False)
        triangles = self._uploads.get("triangles", s.triangles)
        fixed_x, fixed_y = self._buffer("fixed_x", 8 * V), self._buffer("fixed_y", 8 * V)
        depth, valid = self._buffer("depth", 4 * V), self._buffer("valid", 4 * V)
        k["project"](queue, (V,), None, positions, camera, np.float32(W), np.float32(H), fixed_x, fixed_y, depth, valid)
        keys = self._buffer("keys", 8 * W * H)
        k["clear"](queue, (W * H,), None, keys)
        shade = self._buffer("shade", 4 * F)
        k["raster"](queue, (F,), None, triangles, positions, fixed_x, fixed_y, depth, valid, np.int32(W), np.int32(H),
                    np.int32(s.cull), np.int32(s.shaded), *(np.float32(x) for x in s.light), keys, shade)
        host = (np.empty((H, W, 3), np.uint8), np.empty((H, W), np.uint8), np.empty((H, W), np.int32),
                np.empty((H, W), np.float32))
        outputs = [self._buffer(name, a.nbytes) for name, a in zip(("rgb", "labels", "triangle_id", "depth_out"), host)]
        background = s.background if s.shaded else s.palette[0]
        k["resolve"](queue, (W * H,), None, keys, self._uploads.get("part", s.triangle_part), shade,
                     self._uploads.get("colour", s.colour), self._uploads.get("palette", s.palette),
                     *(np.uint8(c) for c in background), np.int32(s.shaded), *outputs)
        for array, device_buffer in zip(host, outputs):
            cl.enqueue_copy(queue, array, device_buffer, is_blocking=False)
        queue.finish()
        return host


_IMPLEMENTATIONS = {"numpy": _NumpyRaster(), "warp": _WarpRaster(), "opencl": _OpenCLRaster()}
