"""Warp bodies of kernels/raster.py: `project` (vertices), `raster` (triangles), `resolve` (image rows).

The steps and the arithmetic are those of the NumPy oracle and of the OpenCL source in
kernels/raster.py; the constants come from there too.

Each thread takes a run of `chunk` items (vertices, triangles, pixels) rather than one: Warp-CPU runs
the threads of a launch one after another, and the per-thread cost (argument copy, call) would
otherwise outweigh the work of the avatar's triangles, which cover a few pixels each. On CUDA the
host layer passes chunk = 1. `resolve` also writes EMPTY_KEY back into every key it reads, so the
next frame starts from a cleared key buffer without a separate clearing pass (chosen here).

Imported by the host layer in kernels/raster.py on first use, so that `import kernels` does not
start Warp; Warp is initialised quietly through kernels.backends.warp().
"""
import warp as wp

from kernels import backends, raster

backends.warp()   # initialise Warp quietly (no banner on stdout) before building kernels

SUBPIXEL = wp.constant(wp.int64(raster.SUBPIXEL))
HALF_SUBPIXEL = wp.constant(wp.int64(raster.HALF_SUBPIXEL))
MIN_CLIP_W = wp.constant(wp.float32(raster.MIN_CLIP_W))
GUARD_PIXELS = wp.constant(wp.float32(raster.GUARD_PIXELS))
DEPTH_SCALE = wp.constant(wp.float32(raster.DEPTH_SCALE))
ID_SCALE = wp.constant(wp.int64(raster.ID_SCALE))
EMPTY_KEY = wp.constant(wp.int64(raster.EMPTY_KEY))


@wp.func
def edge(ax: wp.int64, ay: wp.int64, bx: wp.int64, by: wp.int64, px: wp.int64, py: wp.int64):
    """Integer edge function of edge a->b at p: positive on the inner side of a counter-clockwise walk."""
    return (bx - ax) * (py - ay) - (by - ay) * (px - ax)


@wp.func
def top_left_bias(ax: wp.int64, ay: wp.int64, bx: wp.int64, by: wp.int64):
    """0 where pixels exactly on the edge belong to the triangle (top or left edge), else 1."""
    dx = bx - ax
    dy = by - ay
    if dy < wp.int64(0) or (dy == wp.int64(0) and dx > wp.int64(0)):
        return wp.int64(0)
    return wp.int64(1)


@wp.func
def first_centre(low: wp.int64):
    """First pixel whose centre lies at or after fixed-point coordinate `low` (clipped to 0)."""
    return (wp.max(low, wp.int64(0)) + HALF_SUBPIXEL - wp.int64(1)) / SUBPIXEL


@wp.func
def last_centre(high: wp.int64):
    """Last pixel whose centre lies at or before fixed-point coordinate `high`, -1 if none (high >= 0)."""
    if high < HALF_SUBPIXEL:
        return wp.int64(-1)
    return (high - HALF_SUBPIXEL) / SUBPIXEL


@wp.kernel
def vertex_normals(positions: wp.array(dtype=wp.vec3), triangles: wp.array(dtype=wp.int32),
                   indptr: wp.array(dtype=wp.int32), ids: wp.array(dtype=wp.int32), chunk: wp.int32,
                   normals: wp.array(dtype=wp.vec3)):
    """Vertices [tid * chunk, (tid + 1) * chunk): the unit sum of the area-weighted normals (p1 - p0) x (p2 - p0)
    of the triangles around each vertex (CSR indptr, ids), in ascending triangle order; zero where the sum is."""
    first = wp.tid() * chunk
    for v in range(first, wp.min(first + chunk, positions.shape[0])):
        x = float(0.0)  # noqa: UP018 - Warp: typed variables that the loop below changes
        y = float(0.0)  # noqa: UP018
        z = float(0.0)  # noqa: UP018
        for j in range(indptr[v], indptr[v + 1]):
            t = ids[j]
            p0 = positions[triangles[3 * t]]
            e1 = positions[triangles[3 * t + 1]] - p0
            e2 = positions[triangles[3 * t + 2]] - p0
            x = x + (e1[1] * e2[2] - e1[2] * e2[1])
            y = y + (e1[2] * e2[0] - e1[0] * e2[2])
            z = z + (e1[0] * e2[1] - e1[1] * e2[0])
        length = wp.sqrt(x * x + y * y + z * z)
        if length > 0.0:
            normals[v] = wp.vec3(x / length, y / length, z / length)
        else:
            normals[v] = wp.vec3(0.0, 0.0, 0.0)


@wp.kernel
def project(positions: wp.array(dtype=wp.vec3), m: wp.mat44, width: wp.float32, height: wp.float32,
            chunk: wp.int32, vertices: wp.array(dtype=wp.vec4)):
    """Vertices [tid * chunk, (tid + 1) * chunk) to (window x, window y, depth, valid): x and y in 1/SUBPIXEL
    pixel, whole numbers held exactly in float32 (|x|, |y| < GUARD_PIXELS * SUBPIXEL = 2^23 < 2^24), depth in
    [0, 1], valid 1 where the vertex may be drawn, else 0 (and x = y = 0).

    One 16-byte record a vertex, so the triangle pass reads a vertex with one load (chosen here: four
    separate arrays cost four scattered loads a vertex, and the triangle setup was bound by them)."""
    first = wp.tid() * chunk
    for v in range(first, wp.min(first + chunk, positions.shape[0])):
        p = positions[v]
        cx = m[0, 0] * p[0] + m[0, 1] * p[1] + m[0, 2] * p[2] + m[0, 3]
        cy = m[1, 0] * p[0] + m[1, 1] * p[1] + m[1, 2] * p[2] + m[1, 3]
        cz = m[2, 0] * p[0] + m[2, 1] * p[1] + m[2, 2] * p[2] + m[2, 3]
        cw = m[3, 0] * p[0] + m[3, 1] * p[1] + m[3, 2] * p[2] + m[3, 3]
        ok = cw > MIN_CLIP_W
        w = 1.0
        if ok:
            w = cw
        wx = (cx / w * 0.5 + 0.5) * width
        wy = (0.5 - cy / w * 0.5) * height
        z = cz / w * 0.5 + 0.5
        if wp.abs(wx) >= GUARD_PIXELS or wp.abs(wy) >= GUARD_PIXELS:
            ok = False
        if ok:
            vertices[v] = wp.vec4(wp.floor(wx * wp.float32(SUBPIXEL) + 0.5), wp.floor(wy * wp.float32(SUBPIXEL) + 0.5),
                                  z, 1.0)
        else:
            vertices[v] = wp.vec4(0.0, 0.0, z, 0.0)


@wp.kernel
def raster(triangles: wp.array(dtype=wp.int32), vertices: wp.array(dtype=wp.vec4), width: wp.int32,
           height: wp.int32, cull: wp.int32, chunk: wp.int32, keys: wp.array(dtype=wp.int64),
           row_lo: wp.array(dtype=wp.int32), row_hi: wp.array(dtype=wp.int32)):
    """Triangles [tid * chunk, (tid + 1) * chunk): per-triangle setup, edge functions with the top-left rule over
    the pixel centres inside the bounding box, depth test. Each image row's span of covered pixel centres widens [row_lo, row_hi].
    vertices: the records of `project`."""
    first = wp.tid() * chunk
    for t in range(first, wp.min(first + chunk, triangles.shape[0] / 3)):
        # per-triangle setup: drop triangles with a vertex off limits, degenerate ones, culled back faces
        i0 = triangles[3 * t]
        i1 = triangles[3 * t + 1]
        i2 = triangles[3 * t + 2]
        v0 = vertices[i0]
        v1 = vertices[i1]
        v2 = vertices[i2]
        if v0[3] == 0.0 or v1[3] == 0.0 or v2[3] == 0.0:
            continue
        x0 = wp.int64(v0[0])
        y0 = wp.int64(v0[1])
        x1 = wp.int64(v1[0])
        y1 = wp.int64(v1[1])
        x2 = wp.int64(v2[0])
        y2 = wp.int64(v2[1])
        area = edge(x0, y0, x1, y1, x2, y2)
        if area == wp.int64(0) or (area > wp.int64(0) and cull != 0):
            continue
        # bounding box of the pixel centres the triangle can cover, clipped to the image: a triangle that
        # lies between pixel centres (sub-pixel) or off the image covers none and stops here
        xmin = first_centre(wp.min(wp.min(x0, x1), x2))
        xmax = wp.min(last_centre(wp.max(wp.max(x0, x1), x2)), wp.int64(width - 1))
        if xmax < xmin:
            continue
        ymin = first_centre(wp.min(wp.min(y0, y1), y2))
        ymax = wp.min(last_centre(wp.max(wp.max(y0, y1), y2)), wp.int64(height - 1))
        if ymax < ymin:
            continue
        # window y points down: front faces turn clockwise, area < 0; a back face drawn anyway takes its
        # vertices 1 and 2 swapped, so it turns clockwise like a front face
        z0 = v0[2]
        z1 = v1[2]
        z2 = v2[2]
        if area > wp.int64(0):
            area = -area
            x1 = wp.int64(v2[0])
            y1 = wp.int64(v2[1])
            x2 = wp.int64(v1[0])
            y2 = wp.int64(v1[1])
            z1 = v2[2]
            z2 = v1[2]
        # walking order a, b, c = v0, v2, v1 turns counter-clockwise: edge functions are positive inside
        ax = x0
        ay = y0
        bx = x2
        by = y2
        cx = x1
        cy = y1
        inverse_area = 1.0 / wp.float32(-area)
        dz1 = z1 - z0
        dz2 = z2 - z0
        # edge functions at the pixel centres, with the top-left rule, stepped incrementally across the box
        b0 = top_left_bias(bx, by, cx, cy)
        b1 = top_left_bias(cx, cy, ax, ay)
        b2 = top_left_bias(ax, ay, bx, by)
        start_x = xmin * SUBPIXEL + HALF_SUBPIXEL
        start_y = ymin * SUBPIXEL + HALF_SUBPIXEL
        # biased: covered where all three are >= 0, that is where their bitwise or is (one branch, not three)
        row0 = edge(bx, by, cx, cy, start_x, start_y) - b0
        row1 = edge(cx, cy, ax, ay, start_x, start_y) - b1
        row2 = edge(ax, ay, bx, by, start_x, start_y) - b2
        step_x0 = -(cy - by) * SUBPIXEL
        step_x1 = -(ay - cy) * SUBPIXEL
        step_x2 = -(by - ay) * SUBPIXEL
        step_y0 = (cx - bx) * SUBPIXEL
        step_y1 = (ax - cx) * SUBPIXEL
        step_y2 = (bx - ax) * SUBPIXEL
        # while loops, not range(): a range's step may be negative, and testing for that in the inner loop cost
        # 11% of this kernel's time (chosen here, measured on Warp-CPU)
        row_end = wp.int32(ymax)
        px_start = wp.int32(xmin)
        px_end = wp.int32(xmax)
        py = wp.int32(ymin)
        while py <= row_end:
            e0 = row0
            e1 = row1
            e2 = row2
            base = py * width
            px = px_start
            run_end = int(-1)  # noqa: UP018, RUF046 - Warp: a typed variable that the loop below may change
            while px <= px_end:
                if (e0 | e1 | e2) >= wp.int64(0):
                    if run_end < 0:
                        wp.atomic_min(row_lo, py, px)
                    run_end = px
                    # depth test: interpolate, keep [0, 1], atomic minimum of the key depth * ID_SCALE + triangle
                    l1 = wp.float32(e2 + b2) * inverse_area
                    l2 = wp.float32(e1 + b1) * inverse_area
                    z = z0 + l1 * dz1 + l2 * dz2
                    if z >= 0.0 and z <= 1.0:
                        key = wp.int64(z * DEPTH_SCALE) * ID_SCALE + wp.int64(t)
                        wp.atomic_min(keys, base + px, key)
                elif run_end >= 0:
                    break   # a row's covered pixels are one run (the triangle is convex): none is left
                e0 += step_x0
                e1 += step_x1
                e2 += step_x2
                px += 1
            if run_end >= 0:
                wp.atomic_max(row_hi, py, run_end)
            row0 += step_y0
            row1 += step_y1
            row2 += step_y2
            py += 1


@wp.kernel
def resolve(keys: wp.array(dtype=wp.int64), triangle_part: wp.array(dtype=wp.uint8), palette: wp.array(dtype=wp.uint8),
            background: wp.array(dtype=wp.uint8), shaded: wp.int32, fresh: wp.int32, width: wp.int32, row_lo: wp.array(dtype=wp.int32), row_hi: wp.array(dtype=wp.int32),
            drawn_lo: wp.array(dtype=wp.int32), drawn_hi: wp.array(dtype=wp.int32), rgb: wp.array(dtype=wp.uint8),
            labels: wp.array(dtype=wp.uint8), triangle_id: wp.array(dtype=wp.int32),
            depth_out: wp.array(dtype=wp.float32), triangles: wp.array(dtype=wp.int32),
            vertices: wp.array(dtype=wp.vec4), normals: wp.array(dtype=wp.vec3), colour: wp.array(dtype=wp.uint8),
            light: wp.vec3, ambient: wp.float32, diffuse: wp.float32):
    """Image row tid: each key -> triangle id, label, depth and colour; the key is reset to EMPTY_KEY for the
    next frame.

    The outputs are kept from frame to frame. Unless `fresh`, only the pixels of the row inside this
    frame's span of covered pixels [row_lo, row_hi] or the last frame's [drawn_lo, drawn_hi] are visited (the
    others were empty then and are empty now, so they hold the background already), and an empty pixel
    that was empty in the last frame (triangle id -1) is not written again. The row's spans then move on:
    drawn = this frame's, this frame's = empty for the next raster pass."""
    y = wp.tid()
    lo = wp.min(row_lo[y], drawn_lo[y])
    hi = wp.max(row_hi[y], drawn_hi[y])
    if fresh != 0:
        lo = 0
        hi = width - 1
    drawn_lo[y] = row_lo[y]
    drawn_hi[y] = row_hi[y]
    row_lo[y] = width
    row_hi[y] = -1
    for i in range(y * width + lo, y * width + hi + 1):
        key = keys[i]
        if key == EMPTY_KEY:
            if fresh != 0 or triangle_id[i] != -1:
                labels[i] = wp.uint8(0)
                triangle_id[i] = -1
                depth_out[i] = wp.inf
                rgb[3 * i] = background[0]
                rgb[3 * i + 1] = background[1]
                rgb[3 * i + 2] = background[2]
            continue
        keys[i] = EMPTY_KEY
        t = wp.int32(key % ID_SCALE)
        label = triangle_part[t]
        labels[i] = label
        triangle_id[i] = t
        depth_out[i] = wp.float32(key / ID_SCALE) / DEPTH_SCALE
        if shaded == 0:
            rgb[3 * i] = palette[3 * wp.int32(label)]
            rgb[3 * i + 1] = palette[3 * wp.int32(label) + 1]
            rgb[3 * i + 2] = palette[3 * wp.int32(label) + 2]
        else:
            # the vertex normals interpolated at the pixel centre (barycentric weights from the integer edge
            # functions), normalised, Lambert; a back face drawn turns its normal round
            i0 = triangles[3 * t]
            i1 = triangles[3 * t + 1]
            i2 = triangles[3 * t + 2]
            v0 = vertices[i0]
            v1 = vertices[i1]
            v2 = vertices[i2]
            x0 = wp.int64(v0[0])
            y0 = wp.int64(v0[1])
            x1 = wp.int64(v1[0])
            y1 = wp.int64(v1[1])
            x2 = wp.int64(v2[0])
            y2 = wp.int64(v2[1])
            cx = wp.int64(i - y * width) * SUBPIXEL + HALF_SUBPIXEL
            cy = wp.int64(y) * SUBPIXEL + HALF_SUBPIXEL
            area = wp.float32(edge(x0, y0, x1, y1, x2, y2))
            l1 = wp.float32(edge(x2, y2, x0, y0, cx, cy)) / area
            l2 = wp.float32(edge(x0, y0, x1, y1, cx, cy)) / area
            n0 = normals[i0]
            n1 = normals[i1]
            n2 = normals[i2]
            nx = n0[0] + l1 * (n1[0] - n0[0]) + l2 * (n2[0] - n0[0])
            ny = n0[1] + l1 * (n1[1] - n0[1]) + l2 * (n2[1] - n0[1])
            nz = n0[2] + l1 * (n1[2] - n0[2]) + l2 * (n2[2] - n0[2])
            length = wp.sqrt(nx * nx + ny * ny + nz * nz)
            cosine = float(0.0)  # noqa: UP018 - Warp: a typed variable that the branches below may change
            if length > 0.0:
                cosine = (nx * light[0] + ny * light[1] + nz * light[2]) / length
            if area > 0.0:
                cosine = -cosine
            shade = ambient + diffuse * wp.max(cosine, 0.0)
            rgb[3 * i] = wp.uint8(wp.min(wp.float32(colour[3 * t]) * shade + 0.5, 255.0))
            rgb[3 * i + 1] = wp.uint8(wp.min(wp.float32(colour[3 * t + 1]) * shade + 0.5, 255.0))
            rgb[3 * i + 2] = wp.uint8(wp.min(wp.float32(colour[3 * t + 2]) * shade + 0.5, 255.0))
