"""Vector quantisation of DOF trajectories (seed 002 §7.9): spatial VQ per joint group, temporal VQ per DOF.

Codebooks are trained offline with LBG (binary splitting + Lloyd/k-means iterations, Euclidean
distance) on a training split of the lexicon by tools/train_vq_codebooks.py and shipped in
comparisons/tables/vq_codebooks.npz; they are part of the codec, known to both ends, never sent.

- Spatial VQ (`svq`): each frame of a joint group (e.g. a hand's finger angles) becomes the index of
  the nearest code vector of that group's codebook. q picks the codebook size (16 ... 512).
- Temporal VQ (`tvq`): each DOF is cut into blocks of 6 consecutive samples; a block is coded as the
  nearest code vector of (block - last decoded sample of the previous block), a closed-loop
  (predictive) VQ so one codebook serves every DOF whatever its mean. The first frame is sent as
  16-bit values.

Contract: the DofCoder interface of comparisons/lab/waveform.py (encode, read_levels, decode, SigncastError on bad
input or damaged streams); `nearest(vectors (N, K), codebook (M, K)) -> (N,) int64` indices of the nearest code
vectors (squared Euclidean distance, first index on ties); training (train_codebooks) raises SigncastError for a
size that is not a power of two.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from comparisons.lab.waveform import DofCoder, first_frame_value, read_first_frame, write_first_frame
from media.errors import SigncastError

TABLES_DIR = Path(__file__).resolve().parents[1] / "tables"
VQ_TABLE_PATH = TABLES_DIR / "vq_codebooks.npz"
CODEBOOK_SIZES = (16, 32, 64, 128, 256, 512)
TEMPORAL_DIMENSION = 6


# ---------------------------------------------------------------- training

def nearest(vectors: np.ndarray, codebook: np.ndarray, chunk: int = 4096) -> np.ndarray:
    """Index (N,) of the nearest code vector (Euclidean) for each of vectors (N, k); codebook (M, k)."""
    vectors = np.asarray(vectors, dtype=np.float64)
    codebook = np.asarray(codebook, dtype=np.float64)
    norms = np.einsum("mk,mk->m", codebook, codebook)
    out = np.empty(len(vectors), dtype=np.int64)
    for start in range(0, len(vectors), chunk):
        block = vectors[start:start + chunk]
        out[start:start + chunk] = (norms[None, :] - 2.0 * block @ codebook.T).argmin(axis=1)
    return out


def train_codebooks(vectors: np.ndarray, sizes, iterations: int = 12, seed: int = 0) -> dict[int, np.ndarray]:
    """LBG: start from the centroid, split every code vector in two, refine with Lloyd iterations;
    the codebook reached at each requested size (powers of two) is kept. Empty cells are re-seeded
    at the worst-coded training vectors. Returns {size: (size, k)}."""
    from scipy import sparse

    vectors = np.asarray(vectors, dtype=np.float64)
    sizes = sorted(int(s) for s in sizes)
    if len(vectors) < sizes[-1]:
        raise SigncastError(f"{len(vectors)} training vectors cannot train a codebook of {sizes[-1]}")
    rng = np.random.default_rng(seed)
    codebook = vectors.mean(axis=0, keepdims=True)
    spread = vectors.std(axis=0) + 1e-9
    rows = np.arange(len(vectors))
    books = {}
    while len(codebook) < sizes[-1]:
        n_new = min(len(codebook), sizes[-1] - len(codebook))
        jitter = 1e-2 * spread * rng.standard_normal((n_new, vectors.shape[1]))
        codebook = np.concatenate([codebook, codebook[:n_new] + jitter])
        codebook[:n_new] -= jitter
        for _ in range(iterations):
            index = nearest(vectors, codebook)
            assign = sparse.csr_matrix((np.ones(len(vectors)), (index, rows)), shape=(len(codebook), len(vectors)))
            counts = np.asarray(assign.sum(axis=1)).ravel()
            sums = assign @ vectors
            filled = counts > 0
            codebook[filled] = sums[filled] / counts[filled, None]
            if not filled.all():
                errors = np.sum((vectors - codebook[index]) ** 2, axis=1)
                worst = np.argsort(errors)[::-1][:int((~filled).sum())]
                codebook[~filled] = vectors[worst]
        if len(codebook) in sizes:
            books[len(codebook)] = codebook.copy()
    if 1 in sizes:
        books[1] = vectors.mean(axis=0, keepdims=True)
    return books


def train_codebook(vectors: np.ndarray, size: int, iterations: int = 12, seed: int = 0) -> np.ndarray:
    """One LBG codebook of `size` (a power of two) vectors."""
    if size < 1 or size & (size - 1):
        raise SigncastError(f"LBG codebook size must be a power of two, got {size}")
    return train_codebooks(vectors, [size], iterations, seed)[size]


def temporal_vectors(dofs: np.ndarray, dimension: int = TEMPORAL_DIMENSION) -> np.ndarray:
    """Training vectors of temporal VQ: per DOF, blocks of `dimension` samples minus the sample before."""
    vectors = []
    for start in range(1, len(dofs) - dimension + 1, dimension):
        block = dofs[start:start + dimension].T  # (D, dimension)
        vectors.append(block - dofs[start - 1][:, None])
    return np.concatenate(vectors) if vectors else np.zeros((0, dimension))


# ---------------------------------------------------------------- tables

def load_table_file(path: Path, what: str) -> dict[str, np.ndarray]:
    """Arrays of a shipped .npz table file; a missing or unreadable file names the script that makes it."""
    try:
        with np.load(path, allow_pickle=False) as tables:
            return {key: tables[key] for key in tables.files}
    except OSError:
        raise SigncastError(f"{what} missing ({path}): run tools/train_vq_codebooks.py") from None


def load_vq_tables(path: Path = VQ_TABLE_PATH) -> dict[str, np.ndarray]:
    return load_table_file(path, "VQ codebooks")


def group_layout(tables: dict[str, np.ndarray], dof_names: list[str],
                 prefix: str = "svq") -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(group, DOF indices into dof_names, matching column indices of the group's tables) for each
    group of the tables that has DOFs among dof_names. Every DOF must belong to exactly one group;
    a group's codebooks restricted to the columns present stay valid codebooks of those DOFs."""
    position = {name: i for i, name in enumerate(dof_names)}
    layout = []
    for group in [str(g) for g in tables[f"{prefix}_groups"]]:
        members = [str(n) for n in tables[f"{prefix}_{group}_names"]]
        columns = np.array([c for c, n in enumerate(members) if n in position], dtype=np.int64)
        if len(columns):
            layout.append((group, np.array([position[members[c]] for c in columns], dtype=np.int64), columns))
    covered = np.concatenate([idx for _, idx, _ in layout]) if layout else np.zeros(0, np.int64)
    if sorted(covered.tolist()) != list(range(len(dof_names))):
        raise SigncastError("the groups of the shipped tables do not cover these DOFs exactly once")
    return layout


# ---------------------------------------------------------------- coders

class SpatialVQ(DofCoder):
    """Spatial VQ: one codebook index per joint group per frame (§7.9.1)."""

    name, coder_id, unit = "svq", 8, "codebook size"
    settings = CODEBOOK_SIZES

    def __init__(self, lower, upper, groups: list[np.ndarray], codebooks: list[dict[int, np.ndarray]], *,
                 stage: str | None = None):
        """groups: DOF indices per group; codebooks: per group, {size: (size, len(group)) radians}."""
        super().__init__(lower, upper, stage=stage)
        self.groups = [np.asarray(g, dtype=np.int64) for g in groups]
        self.codebooks = [{int(k): np.asarray(v, dtype=np.float64) for k, v in books.items()} for books in codebooks]

    def _encode(self, writer, dofs, fps, size):
        recon = np.empty_like(dofs)
        for group, books in zip(self.groups, self.codebooks):
            index = nearest(dofs[:, group], books[size])
            writer.symbols(index, size)
            recon[:, group] = books[size][index]
        return recon

    def _read(self, reader, n_frames, size):
        """{"index.g": (T,) codebook indices of group g, g = 0, 1, ...}."""
        return {f"index.{g}": reader.symbols(size, n_frames) for g in range(len(self.groups))}

    def _rebuild(self, read, n_frames, fps, size):
        recon = np.empty((n_frames, self.n_dofs))
        for g, (group, books) in enumerate(zip(self.groups, self.codebooks)):
            recon[:, group] = books[size][read[f"index.{g}"]]
        return recon


class TemporalVQ(DofCoder):
    """Temporal VQ: blocks of 6 samples per DOF, predicted from the last decoded sample (§7.9.2)."""

    name, coder_id, unit = "tvq", 9, "codebook size"
    settings = CODEBOOK_SIZES

    def __init__(self, lower, upper, codebooks: dict[int, np.ndarray], *, stage: str | None = None):
        """codebooks: {size: (size, 6) radians} shared by all DOFs."""
        super().__init__(lower, upper, stage=stage)
        self.codebooks = {int(k): np.asarray(v, dtype=np.float64) for k, v in codebooks.items()}

    def _run(self, first, n_frames, book, dofs=None, symbols=None):
        dim = book.shape[1]
        n_blocks = -(-(n_frames - 1) // dim)
        recon = np.empty((1 + n_blocks * dim, self.n_dofs))
        recon[0] = first
        if dofs is not None:
            padded = np.pad(dofs, ((0, len(recon) - n_frames), (0, 0)), mode="edge")
            symbols = np.empty((n_blocks, self.n_dofs), dtype=np.int64)
        for b in range(n_blocks):
            start = 1 + b * dim
            anchor = recon[start - 1]
            if dofs is not None:
                symbols[b] = nearest((padded[start:start + dim] - anchor).T, book)
            recon[start:start + dim] = (anchor[:, None] + book[symbols[b]]).T
        return recon[:n_frames], symbols

    def _encode(self, writer, dofs, fps, size):
        first = write_first_frame(writer, self, dofs[0])
        recon, symbols = self._run(first, len(dofs), self.codebooks[size], dofs=dofs)
        writer.symbols(symbols, size)
        return recon

    def _read(self, reader, n_frames, size):
        """{"first": (D,) first-frame cells, "symbols": (n_blocks, D) codebook indices of the 6-sample blocks}."""
        first = read_first_frame(reader, self)
        n_blocks = -(-(n_frames - 1) // TEMPORAL_DIMENSION)
        return {"first": first, "symbols": reader.symbols(size, n_blocks * self.n_dofs).reshape(n_blocks, self.n_dofs)}

    def _rebuild(self, read, n_frames, fps, size):
        return self._run(first_frame_value(read["first"], self), n_frames, self.codebooks[size],
                         symbols=read["symbols"])[0]


def spatial_vq(lower, upper, dof_names: list[str], tables: dict | None = None, stage: str | None = None) -> SpatialVQ:
    tables = tables if tables is not None else load_vq_tables()
    layout = group_layout(tables, dof_names)
    books = [{size: tables[f"svq_{group}_{size}"][:, columns] for size in CODEBOOK_SIZES}
             for group, _, columns in layout]
    return SpatialVQ(lower, upper, [idx for _, idx, _ in layout], books, stage=stage)


def temporal_vq(lower, upper, tables: dict | None = None, stage: str | None = None) -> TemporalVQ:
    tables = tables if tables is not None else load_vq_tables()
    return TemporalVQ(lower, upper, {size: tables[f"tvq_{size}"] for size in CODEBOOK_SIZES}, stage=stage)
