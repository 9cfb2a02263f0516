"""Write tests/data/codec_letter_motions.npz: ASL letters A and J at 25 fps as media.fingerspelling.letter_motion
retargets them (bone rotations, root translation, FAPs), the inputs of tests/test_bba_speed_identity.py's hash of
the BBA codecs.

Stored, not retargeted live, because retargeting's last bits depend on the CPU (NumPy's SIMD dispatch and
OpenBLAS's kernels sum in different orders); the codecs downstream of it do not. The stored file was written
with NumPy's AVX-512 paths off and OpenBLAS's Haswell kernels, the configuration the test's digest was first
taken on:

    NPY_DISABLE_CPU_FEATURES="AVX512F AVX512CD AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR X86_V4" \\
    OPENBLAS_CORETYPE=Haswell python tools/make_codec_letter_motions.py
"""
from pathlib import Path

import numpy as np

from media.fingerspelling import letter_motion

OUT = Path(__file__).resolve().parents[1] / "tests" / "data" / "codec_letter_motions.npz"


def main() -> None:
    arrays = {}
    for letter in "AJ":
        motion = letter_motion("ase", letter, 25.0)
        arrays.update({f"{letter}/fps": np.float64(motion.fps), f"{letter}/bone_names": np.array(motion.bone_names),
                       f"{letter}/rotations": motion.rotations, f"{letter}/root_translation": motion.root_translation,
                       f"{letter}/faps": motion.faps})
    np.savez_compressed(OUT, **arrays)
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
