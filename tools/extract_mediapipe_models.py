"""Extract the MediaPipe landmark models signcast uses from the `mediapipe==0.10.14` wheel.

Usage: python tools/extract_mediapipe_models.py [WHEEL]

Without WHEEL it runs `pip download mediapipe==0.10.14 --no-deps` into a temporary folder (the only
network use, here in a tool, never at run time). It copies the `.tflite` files of MODELS from
`mediapipe/modules/` and the wheel's Apache-2.0 licence to `media/assets/mediapipe/`, and writes
`models.sha256` (checked by `media.landmarks.models` when a model is loaded) and the provenance table.
The mediapipe wheel itself cannot be a dependency: it requires jax and the non-headless OpenCV.
"""
from __future__ import annotations

import hashlib
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

VERSION = "0.10.14"
# file in the wheel's mediapipe/modules/ -> what signcast uses it for
MODELS = {
    "pose_detection/pose_detection.tflite": "person detector (BlazePose detector, 224x224)",
    "pose_landmark/pose_landmark_full.tflite": "33 body landmarks in the person's rotated ROI (256x256)",
    "palm_detection/palm_detection_full.tflite": "palm detector, the fallback for hand ROIs (192x192)",
    "hand_landmark/hand_landmark_full.tflite": "21 hand landmarks in the hand's rotated ROI (224x224)",
    "holistic_landmark/hand_recrop.tflite": "refines a hand ROI predicted from the pose (256x256)",
    "face_detection/face_detection_short_range.tflite": "face detector, the fallback for the face ROI (128x128)",
    "face_landmark/face_landmark.tflite": "468-point face mesh in the face's rotated ROI (192x192)",
    "iris_landmark/iris_landmark.tflite": "5 iris points per eye (points 468-477 of the 478 layout, 64x64)",
    "selfie_segmentation/selfie_segmentation.tflite": "person mask (256x256)",
}
ASSETS = Path(__file__).resolve().parent.parent / "media" / "assets" / "mediapipe"


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def extract(wheel: Path) -> None:
    ASSETS.mkdir(parents=True, exist_ok=True)
    wheel_hash = sha256(wheel.read_bytes())
    rows, sums = [], []
    with zipfile.ZipFile(wheel) as archive:
        licence = archive.read(f"mediapipe-{VERSION}.dist-info/LICENSE")
        (ASSETS / "LICENSE-mediapipe-Apache-2.0.txt").write_bytes(licence)
        for member, use in MODELS.items():
            data = archive.read(f"mediapipe/modules/{member}")
            name = Path(member).name
            (ASSETS / name).write_bytes(data)
            rows.append(f"| `mediapipe/modules/{member}` | {len(data):,} | {use} | {sha256(data)} |")
            sums.append(f"{sha256(data)}  {name}")
    (ASSETS / "models.sha256").write_text("\n".join(sums) + "\n")
    (ASSETS / "PROVENANCE.md").write_text(
        "# media/assets/mediapipe: provenance\n\n"
        "MediaPipe's landmark models, **Apache License 2.0** (licence text: `LICENSE-mediapipe-Apache-2.0.txt`,\n"
        f"copied from the wheel's `dist-info`), Copyright The MediaPipe Authors. Taken unchanged from the\n"
        f"`mediapipe=={VERSION}` wheel on PyPI (`{wheel.name}`, sha256 {wheel_hash})\n"
        "by `tools/extract_mediapipe_models.py`. They run with `ai-edge-litert`; the graph that connects\n"
        "them (detection, rotated ROIs, tracking: MediaPipe Holistic's) is signcast's own, in `media/landmarks/`.\n\n"
        "| file in the wheel | bytes | used for | sha256 |\n|---|---|---|---|\n" + "\n".join(rows) + "\n")
    print(f"wrote {len(MODELS)} models to {ASSETS}")


def main(argv: list[str]) -> int:
    if len(argv) > 1:
        extract(Path(argv[1]))
        return 0
    with tempfile.TemporaryDirectory() as folder:
        subprocess.run([sys.executable, "-m", "pip", "download", f"mediapipe=={VERSION}", "--no-deps",
                        "--only-binary", ":all:", "-d", folder], check=True)
        extract(next(Path(folder).glob("mediapipe-*.whl")))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
