"""Frames per second of the synthetic signer's kernels against the OpenGL software renderer.

Measures, in one run, on the default avatar (26,756 skin triangles + eyes) posed by real ASL
fingerspelling, at 352x288 (change with --size):
  * skinning alone (linear blend skinning of the rest mesh with one frame's bone matrices),
  * rasterization alone (pre-skinned positions -> rgb, labels, triangle ids, depth),
  * skinning + rasterization,
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

    python benchmarks/render.py [--size 352x288] [--frames 60] [--repeats 3] [--word HELLO]
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


def posed_sequence(word: str, width: int, height: int, frames: int):
    """Avatar, camera, per-frame bone matrices (float32) and pre-skinned positions of a fingerspelled word."""
    from kernels.skinning import skin
    from media.avatar import load_avatar
    from media.fingerspelling import fingerspell
    from media.kinematics import bone_matrices
    from media.render import signing_space_camera
    avatar = load_avatar()
    motion = fingerspell("ase", word, 25.0)
    matrices = bone_matrices(avatar.skeleton, motion).astype(np.float32)
    index = np.arange(frames) % len(matrices)
    matrices = matrices[index]
    positions = [skin(avatar.vertices, avatar.weights, m, backend="numpy") for m in matrices]
    return avatar, signing_space_camera(avatar, width, height), matrices, positions


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


def measure_backend(backend: str, avatar, camera, matrices, positions, width, height, frames) -> dict:
    """One round of frames/s for skinning, rasterization, and both, on one backend."""
    from kernels.raster import rasterize
    from kernels.skinning import skin
    from media.render import triangle_colours
    weights = avatar.weights
    colours = triangle_colours(avatar)
    n = len(matrices)

    def skinning(i):
        skin(avatar.vertices, weights, matrices[i % n], backend=backend)

    def raster(i):
        rasterize(positions[i % n], avatar.triangles, avatar.triangle_part, camera, width, height,
                  triangle_colour=colours, backend=backend)

    def both(i):
        posed = skin(avatar.vertices, weights, matrices[i % n], backend=backend)
        rasterize(posed, avatar.triangles, avatar.triangle_part, camera, width, height,
                  triangle_colour=colours, backend=backend)

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
    except Exception as error:  # the EGL/Mesa libraries are missing or broken
        print(json.dumps({"skip": f"no EGL context ({str(error).splitlines()[0]}); apt-get install {PEER_PACKAGES}"}))
        return
    width, height = arguments.width, arguments.height
    avatar, camera, _, positions = posed_sequence(arguments.word, width, height, arguments.frames)
    program = context.program(vertex_shader=_VERTEX_SHADER, fragment_shader=_FRAGMENT_SHADER)
    program["camera"].write(np.ascontiguousarray(camera.T, dtype=np.float32).tobytes())
    program["light"].value = tuple(float(x) for x in np.array([0.35, 0.45, 1.0]) / np.linalg.norm([0.35, 0.45, 1.0]))
    vertices = context.buffer(reserve=positions[0].nbytes, dynamic=True)
    indices = context.buffer(avatar.triangles.astype(np.uint32).tobytes())
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
               "--frames", str(arguments.frames), "--repeats", "1", "--word", arguments.word]
    result = subprocess.run(command, capture_output=True, text=True, env=environment, timeout=900)
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
        result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=900)
        wall = time.perf_counter() - started
    if result.returncode != 0:
        return {"skip": f"signcast render failed: {result.stderr.strip().splitlines()[-1:]}"}
    frames = int(re.search(r"(\d+) frames", result.stdout).group(1))
    with_encoding = float(re.search(r"([\d.]+) frames/s with encoding", result.stdout).group(1))
    return {"frames": frames, "render+encode": with_encoding, "process": frames / wall}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", default="352x288")
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--word", default="HELLO")
    parser.add_argument("--backends", default="numpy,warp,opencl")
    parser.add_argument("--peer-worker", action="store_true", help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    arguments.width, arguments.height = (int(x) for x in arguments.size.lower().split("x"))
    if arguments.peer_worker:
        peer_worker(arguments)
        return

    from kernels import backends
    avatar, camera, matrices, positions = posed_sequence(arguments.word, arguments.width, arguments.height,
                                                         arguments.frames)
    print(f"avatar: {len(avatar.vertices)} vertices, {len(avatar.triangles)} triangles; "
          f"{arguments.width}x{arguments.height}; {arguments.frames} frames x {arguments.repeats} repeats (median); "
          f"{os.cpu_count()} CPUs", flush=True)
    # Rounds interleave every renderer, so that load from other processes on the machine falls on all
    # of them alike; each figure is the median over the rounds.
    labels, samples, skipped = {}, {}, {}
    for backend in arguments.backends.split(","):
        try:
            labels[backend] = backends.describe(backend)
        except Exception as error:  # report and go on with the other backends
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
                result = measure_backend(key, avatar, camera, matrices, positions, arguments.width,
                                         arguments.height, arguments.frames)
            for name, value in result.items():
                if isinstance(value, float):
                    samples.setdefault(key, {}).setdefault(name, []).append(value)
        print(f"round {round_ + 1}/{arguments.repeats} done", file=sys.stderr, flush=True)
    for key, reason in skipped.items():
        print(f"{labels[key]} skipped: {reason}", flush=True)
    rows = {labels[key]: {name: statistics.median(values) for name, values in figures.items()}
            for key, figures in samples.items()}
    command = measure_command(arguments)

    print()
    print(f"{'renderer':<44} {'skin fps':>10} {'raster fps':>11} {'skin+raster fps':>16}")
    for label, row in rows.items():
        cells = [f"{row[k]:>{w}.1f}" if k in row else f"{'-':>{w}}" for k, w in
                 (("skin", 10), ("raster", 11), ("skin+raster", 16))]
        print(f"{label:<44} {' '.join(cells)}")
    print()

    def find(prefix):
        return next((row for label, row in rows.items() if label.startswith(prefix)), None)

    try:
        load = ", load average %.1f %.1f %.1f" % os.getloadavg()
    except OSError:
        load = ""
    print(f"(after the run{load})")

    warp, opencl = find("warp"), find("opencl")
    peer1, peer2 = find("llvmpipe 1"), find("llvmpipe 2")
    ratios = [("Warp skin+raster / llvmpipe 1 thread (target >= 1)", warp, "skin+raster", peer1),
              ("Warp raster / llvmpipe 1 thread", warp, "raster", peer1),
              ("OpenCL skin+raster / llvmpipe 2 threads (target >= 1)", opencl, "skin+raster", peer2),
              ("OpenCL raster / llvmpipe 2 threads", opencl, "raster", peer2)]
    for text, ours, key, peer in ratios:
        if ours and peer:
            print(f"{text:<56} {ours[key] / peer['raster']:.2f}")
    if "skip" in command:
        print(f"signcast render: {command['skip']}")
    else:
        print(f"signcast render ase {arguments.word} ({command['frames']} frames, backend auto): "
              f"{command['render+encode']:.1f} fps render+encode, {command['process']:.1f} fps whole process "
              f"(target >= 25)")


if __name__ == "__main__":
    main()
