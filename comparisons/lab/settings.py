"""The motion lab's fixed settings (which languages it charts, which MPEG-4 codecs and Q it sets beside the
seed-002 coders), without the coders themselves: the command line's parsers read them, and importing the
coders (SciPy's signal and statistics packages among them) would add over a second to every `signcast` command.
"""
from media.domain import MOTION_CODER_NAMES

EVALUATION_LANGUAGES = ("ase", "gsg", "tsm")  # charted; never used to train tables (tools/train_vq_codebooks.py)
MPEG4_CODECS = ("fba-pred", "fba-dct", "bba-pred", "bba-dct")
MPEG4_Q = (1, 2, 4, 8, 16, 31)
FPS = 25.0
DEFAULT_CODECS = tuple(MOTION_CODER_NAMES) + MPEG4_CODECS
