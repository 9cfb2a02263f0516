"""Frames per second of the synthetic signer's kernels against the OpenGL software renderer.

Measures, in one run, on the default avatar (26,756 skin triangles + eyes) posed by real ASL
fingerspelling, at 352x288 and 640x480 (change with --size, a comma-separated list), and a frame with
two avatars side by side (two posed copies of the mesh, the second one half the word further on, skinned
as one mesh with both copies' bones,
54,072 triangles; at --two-avatars-size, default 352x288, empty to skip):
  * skinning alone (linear blend skinning of the rest mesh with one frame's bone matrices),
  * rasterization alone (pre-skinned positions -> rgb, labels, triangle ids, depth),
  * skinning + rasterization, in one call as the renderer makes it (kernels/skinned_raster.py: on OpenCL
    the posed skin stays on the device),
for each kernels backend (NumPy oracle, Warp on its device, OpenCL on its device); then the peer,
Mesa llvmpipe through moderngl with an EGL surfaceless context, drawing the same pre-skinned
meshes with the same camera (upload + draw with depth test and back-face culling + RGB readback),
with one and with two llvmpipe threads; then `signcast render` end to end (fingerspelling, FK,
muscles, skinning, rasterization, lossless FFV1 encoding), as a separate process.

Each figure is the median of --repeats rounds of --frames frames after a warm-up; the rounds
interleave the renderers so that other load on the machine hits them alike. Nothing is
asserted; the table gives ratios. The peer needs Debian's libegl-mesa0 libegl1 libgl1-mesa-dri
libgl1 libgles2 libglx-mesa0 libgbm1 and PyPI's moderngl (`pip install -e .[bench]`); without them it
is skipped with a message.

    python benchmarks/render.py [--size 352x288,640x480] [--two-avatars-size 352x288] [--frames 60]
                                [--repeats 3] [--word HELLO]
"""
from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PEER_PACKAGES = "libegl-mesa0 libegl1 libgl1-mesa-dri libgl1 libgles2 libglx-mesa0 libgbm1"


class Scene:
    """What one benchmark frame draws: `copies` posed copies of the avatar side by side, as one skinned mesh.

    rest (copies * V, 3) float32 and weights (CSR, each copy's bones numbered after the last copy's): the
    copies' skin; triangles (F, 3) int32, triangle_part (F,) uint8, colours (F, 3) uint8 of all copies;
    camera (4, 4) float32; matrices: per frame, (copies * B, 4, 4) float32 bone matrices, copy c's shifted by
    offsets[c] and posed c / copies of the word further on; positions: per frame, the (copies * V, 3) float32
    skin posed by the NumPy oracle (what the peer draws); offsets: (copies, 3) float32 world shift of each copy.
    """

    def __init__(self, word: str, width: int, height: int, frames: int, copies: int = 1):
        from kernels import immutable
        from kernels.skinning import SkinWeights
        from media.avatar import load_avatar
        from media.fingerspelling import fingerspell
        from media.kinematics import bone_matrices
        from media.render import signing_space_camera, triangle_colours
        avatar = self.avatar = load_avatar()
        motion = fingerspell("ase", word, 25.0)
        matrices = bone_matrices(avatar.skeleton, motion).astype(np.float32)
        n = len(matrices)
        if copies == 1:
            self.camera = signing_space_camera(avatar, width, height)
            self.offsets = np.zeros((1, 3), np.float32)
        else:
            # Each copy gets an equal slice of the width: the one-avatar camera for that slice, squeezed
            # in clip x; the copies stand apart by the slice's width at the avatar's depth (z = 0).
            single = signing_space_camera(avatar, max(width // copies, 1), height)
            centre = np.append(avatar.vertices.mean(axis=0), 1.0)
            half_width = float(single[3] @ centre) / float(single[0, 0])
            self.camera = (np.diag([1.0 / copies, 1, 1, 1]) @ single).astype(np.float32)
            self.offsets = np.array([[(2 * c - copies + 1) * half_width, 0, 0] for c in range(copies)], np.float32)
        # Immutable, like the renderer's own static arrays (media/render.py), so that the kernels upload
        # and check them once, the way the peer keeps its index buffer.
        V, B, weights = len(avatar.vertices), matrices.shape[1], avatar.weights
        if copies == 1:
            self.rest, self.weights = avatar.vertices, weights
        else:
            nnz = len(weights.bones)
            self.rest = immutable(np.tile(avatar.vertices, (copies, 1)))
            self.weights = SkinWeights(
                immutable(np.concatenate([weights.indptr[:-1] + c * nnz for c in range(copies)] + [[copies * nnz]])
                          .astype(np.int32)),
                immutable(np.concatenate([weights.bones + c * B for c in range(copies)]).astype(np.int32)),
                immutable(np.tile(weights.values, copies)))
        self.triangles = immutable(np.concatenate([avatar.triangles + c * V for c in range(copies)]).astype(np.int32))
        self.triangle_part = immutable(np.tile(avatar.triangle_part, copies))
        self.colours = immutable(np.tile(triangle_colours(avatar), (copies, 1)))
        self.matrices = []
        for i in range(frames):
            posed = np.concatenate([matrices[(i + c * n // copies) % n] for c in range(copies)])
            posed[:, :3, 3] += np.repeat(self.offsets, B, axis=0)
            self.matrices.append(posed)
        self.positions = [self.pose(m, "numpy") for m in self.matrices]

    def pose(self, matrices, backend: str) -> np.ndarray:
        """(copies * V, 3) float32 skin of every copy, posed by one frame's bone matrices."""
        from kernels.skinning import skin
        return skin(self.rest, self.weights, matrices, backend=backend)


def frames_per_second(step, frames: int, repeats: int, warmup: int = 5) -> float:
    for i in range(warmup):
        step(i)
    rates = []
    for _ in range(repeats):
        started = time.perf_counter()
        for i in range(frames):
            step(i)
        rates.append(frames / (time.perf_counter() - started))
    return statistics.median(rates)


def measure_backend(backend: str, scene: Scene, width, height, frames) -> dict:
    """One round of frames/s for skinning, rasterization, and both, on one backend."""
    from kernels.raster import rasterize
    from kernels.skinned_raster import skin_and_rasterize
    n = len(scene.matrices)

    def skinning(i):
        scene.pose(scene.matrices[i % n], backend)

    def raster(i):
        rasterize(scene.positions[i % n], scene.triangles, scene.triangle_part, scene.camera, width, height,
                  triangle_colour=scene.colours, backend=backend)

    def both(i):               # as the renderer draws a frame (media/render.py AvatarRenderer.render_pose)
        skin_and_rasterize(scene.rest, scene.weights, scene.matrices[i % n], scene.triangles, scene.triangle_part,
                           scene.camera, width, height, triangle_colour=scene.colours, backend=backend)

    count = max(frames // 6, 5) if backend == "numpy" else frames
    return {"skin": frames_per_second(skinning, count * 4, 1),
            "raster": frames_per_second(raster, count, 1),
            "skin+raster": frames_per_second(both, count, 1)}


# --- the OpenGL peer --------------------------------------------------------------------------------

_VERTEX_SHADER = """
#version 330
uniform mat4 camera;
in vec3 position;
out vec3 world;
void main() { world = position; gl_Position = camera * vec4(position, 1.0); }
"""
_FRAGMENT_SHADER = """
#version 330
uniform vec3 light;
in vec3 world;
out vec4 colour;
void main() {
    vec3 n = normalize(cross(dFdx(world), dFdy(world)));
    float lambert = 0.30 + 0.75 * abs(dot(n, light));
    colour = vec4(vec3(0.18, 0.20, 0.27) * lambert, 1.0);
}
"""


def peer_worker(arguments) -> None:
    """Run in a child process (llvmpipe reads LP_NUM_THREADS when the context starts); prints JSON."""
    os.environ.setdefault("EGL_PLATFORM", "surfaceless")
    try:
        import moderngl
    except ImportError:
        print(json.dumps({"skip": "moderngl is not installed (pip install -e .[bench] or pip install moderngl)"}))
        return
    try:
        context = moderngl.create_standalone_context(backend="egl")
    except Exception as error:  # noqa: BLE001 - the EGL/Mesa libraries are missing or broken
        print(json.dumps({"skip": f"no EGL context ({str(error).splitlines()[0]}); apt-get install {PEER_PACKAGES}"}))
        return
    width, height = arguments.width, arguments.height
    scene = Scene(arguments.word, width, height, arguments.frames, arguments.copies)
    positions = scene.positions
    program = context.program(vertex_shader=_VERTEX_SHADER, fragment_shader=_FRAGMENT_SHADER)
    program["camera"].write(np.ascontiguousarray(scene.camera.T, dtype=np.float32).tobytes())
    program["light"].value = tuple(float(x) for x in np.array([0.35, 0.45, 1.0]) / np.linalg.norm([0.35, 0.45, 1.0]))
    vertices = context.buffer(reserve=positions[0].nbytes, dynamic=True)
    indices = context.buffer(scene.triangles.astype(np.uint32).tobytes())
    vao = context.vertex_array(program, [(vertices, "3f", "position")], index_buffer=indices, index_element_size=4)
    framebuffer = context.framebuffer(color_attachments=[context.renderbuffer((width, height))],
                                      depth_attachment=context.depth_renderbuffer((width, height)))
    context.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
    image = bytearray(width * height * 3)
    n = len(positions)

    def draw(i):
        vertices.write(positions[i % n].tobytes())
        framebuffer.use()
        framebuffer.clear(0.36, 0.44, 0.5, 1.0, depth=1.0)
        vao.render(moderngl.TRIANGLES)
        framebuffer.read_into(image, components=3)

    fps = frames_per_second(draw, arguments.frames, arguments.repeats)
    print(json.dumps({"raster": fps, "renderer": context.info["GL_RENDERER"]}))


def measure_peer(threads: int, arguments) -> dict:
    """One round of the peer in a child process with `threads` llvmpipe threads."""
    environment = dict(os.environ, LP_NUM_THREADS=str(threads), EGL_PLATFORM="surfaceless")
    command = [sys.executable, __file__, "--peer-worker", "--size", f"{arguments.width}x{arguments.height}",
               "--frames", str(arguments.frames), "--repeats", "1", "--word", arguments.word,
               "--copies", str(arguments.copies)]
    result = subprocess.run(command, check=False, capture_output=True, text=True, env=environment, timeout=900)
    lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
    if result.returncode != 0 or not lines:
        return {"skip": f"peer failed: {(result.stderr.strip().splitlines() or ['no output'])[-1]}"}
    return json.loads(lines[-1])


def measure_command(arguments) -> dict:
    """`signcast render` as a user runs it: whole process wall time and the command's own render+encode rate."""
    with tempfile.TemporaryDirectory() as folder:
        output = Path(folder) / "word.mkv"
        command = [sys.executable, "-m", "pipeline.cli", "render", "ase", arguments.word, "-o", str(output),
                   "--labels", str(Path(folder) / "labels.npz"), "--size", f"{arguments.width}x{arguments.height}"]
        started = time.perf_counter()
        result = subprocess.run(command, check=False, capture_output=True, text=True, cwd=ROOT, timeout=900)
        wall = time.perf_counter() - started
    if result.returncode != 0:
        return {"skip": f"signcast render failed: {result.stderr.strip().splitlines()[-1:]}"}
    frames = int(re.search(r"(\d+) frames", result.stdout).group(1))
    with_encoding = float(re.search(r"([\d.]+) frames/s with encoding", result.stdout).group(1))
    return {"frames": frames, "render+encode": with_encoding, "process": frames / wall}


def measure_scene(arguments, width: int, height: int, copies: int) -> None:
    """Interleaved rounds of every renderer on one scene and size; prints its table and the ratios."""
    from kernels import backends
    arguments = argparse.Namespace(**{**vars(arguments), "width": width, "height": height, "copies": copies})
    scene = Scene(arguments.word, width, height, arguments.frames, copies)
    print(f"\n== {copies} avatar{'s' if copies > 1 else ''}: {len(scene.positions[0])} vertices, "
          f"{len(scene.triangles)} triangles; {width}x{height}; {arguments.frames} frames x {arguments.repeats} "
          f"repeats (median); {os.cpu_count()} CPUs", flush=True)
    # Rounds interleave every renderer, so that load from other processes on the machine falls on all
    # of them alike; each figure is the median over the rounds.
    labels, samples, skipped = {}, {}, {}
    for backend in arguments.backends.split(","):
        try:
            labels[backend] = backends.describe(backend)
        except Exception as error:  # noqa: BLE001 - report and go on with the other backends
            print(f"{backend}: skipped ({error})", flush=True)
    for threads in (1, 2):
        labels[f"peer{threads}"] = f"llvmpipe {threads} thread{'s' if threads > 1 else ''} (moderngl+EGL)"
    for round_ in range(arguments.repeats):
        for key in list(labels):
            if key in skipped:
                continue
            if key.startswith("peer"):
                result = measure_peer(int(key[-1]), arguments)
                if "skip" in result:
                    skipped[key] = result["skip"]
                    continue
            else:
                result = measure_backend(key, scene, width, height, arguments.frames)
            for name, value in result.items():
                if isinstance(value, float):
                    samples.setdefault(key, {}).setdefault(name, []).append(value)
        print(f"round {round_ + 1}/{arguments.repeats} done", file=sys.stderr, flush=True)
    for key, reason in skipped.items():
        print(f"{labels[key]} skipped: {reason}", flush=True)
    rows = {labels[key]: {name: statistics.median(values) for name, values in figures.items()}
            for key, figures in samples.items()}

    print(f"{'renderer':<44} {'skin fps':>10} {'raster fps':>11} {'skin+raster fps':>16}")
    for label, row in rows.items():
        cells = [f"{row[k]:>{w}.1f}" if k in row else f"{'-':>{w}}" for k, w in
                 (("skin", 10), ("raster", 11), ("skin+raster", 16))]
        print(f"{label:<44} {' '.join(cells)}")

    def find(prefix):
        return next((row for label, row in rows.items() if label.startswith(prefix)), None)

    try:
        load = ", load average {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())
    except OSError:
        load = ""
    print(f"(after the run{load})")
    warp, opencl = find("warp"), find("opencl")
    peer1, peer2 = find("llvmpipe 1"), find("llvmpipe 2")
    ratios = [("Warp skin+raster / llvmpipe 1 thread (target >= 2)", warp, "skin+raster", peer1),
              ("Warp raster / llvmpipe 1 thread", warp, "raster", peer1),
              ("OpenCL skin+raster / llvmpipe 2 threads (target >= 2)", opencl, "skin+raster", peer2),
              ("OpenCL raster / llvmpipe 2 threads", opencl, "raster", peer2)]
    for text, ours, key, peer in ratios:
        if ours and peer:
            print(f"{text:<56} {ours[key] / peer['raster']:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", default="352x288,640x480", help="comma-separated WxH list (one avatar)")
    parser.add_argument("--two-avatars-size", default="352x288", help="WxH of the two-avatar frame ('' skips it)")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--word", default="HELLO")
    parser.add_argument("--backends", default="numpy,warp,opencl")
    parser.add_argument("--no-command", action="store_true", help="skip timing `signcast render`")
    parser.add_argument("--copies", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--peer-worker", action="store_true", help=argparse.SUPPRESS)
    arguments = parser.parse_args()

    def size(text):
        width, height = (int(x) for x in text.lower().split("x"))
        return width, height

    if arguments.peer_worker:
        arguments.width, arguments.height = size(arguments.size)
        peer_worker(arguments)
        return
    sizes = [size(s) for s in arguments.size.split(",") if s]
    scenes = [(w, h, 1) for w, h in sizes]
    if arguments.two_avatars_size:
        scenes.append((*size(arguments.two_avatars_size), 2))
    for width, height, copies in scenes:
        measure_scene(arguments, width, height, copies)
    if arguments.no_command or not sizes:
        return
    arguments.width, arguments.height = sizes[0]
    command = measure_command(arguments)
    print()
    if "skip" in command:
        print(f"signcast render: {command['skip']}")
    else:
        print(f"signcast render ase {arguments.word} ({command['frames']} frames, backend auto, "
              f"{arguments.width}x{arguments.height}): {command['render+encode']:.1f} fps render+encode, "
              f"{command['process']:.1f} fps whole process (target >= 25)")


if __name__ == "__main__":
    main()
