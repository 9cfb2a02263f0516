"""Where the commands write: output folders and files, checked before the work, and never lost to a failed run.

An output folder (`--out DIR`):
- must be a folder, or not exist yet; its missing parents are created;
- must be empty or not exist, unless `--force`;
- the run writes into a temporary folder beside it (`.DIR.signcast-partial-PID`), created before any work, so a
  place that cannot take files is refused first (also when running as root);
- when the run succeeds, what it wrote is moved into DIR: DIR itself when DIR did not exist, else file by file,
  after removing the files an earlier signcast run wrote there (listed in DIR's manifest, MANIFEST; with
  `--force` only); a file of the same name is replaced, any other file is kept;
- a run that fails (an error, a bug, Ctrl-C or SIGINT) removes the temporary folder: DIR stays exactly as it was,
  old results included;
- after a successful run, MANIFEST lists every file the run wrote (paths relative to the folder).

An output file (`-o FILE`, `--labels FILE`, ...): its folder must exist; an existing file is replaced only with
`--force`; the file is created (or opened for appending, which changes nothing) before the work, and a failed run
removes the files it created.

Every refusal is a SigncastError: one line on stderr and exit code 2.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator

from media.errors import SigncastError

MANIFEST = ".signcast-files"
PARTIAL = ".signcast-partial-"


def _reason(error: OSError) -> str:
    return error.strerror or str(error)


def _files(folder: Path) -> dict[Path, tuple[int, int]]:
    """Every file below folder (recursively) -> (mtime_ns, size)."""
    found = {}
    for root, _, names in os.walk(folder):
        for name in names:
            path = Path(root) / name
            try:
                status = path.stat()
            except OSError:
                continue
            found[path] = (status.st_mtime_ns, status.st_size)
    return found


def _probe(folder: Path, shown: Path) -> None:
    """Create and remove a file in folder: the one check of writability that holds for root and read-only mounts."""
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".signcast-probe-"):
            pass
    except OSError as error:
        raise SigncastError(f"cannot write to {shown}: {_reason(error)}") from None


def _make_folder(folder: Path, shown: Path) -> list[Path]:
    """Create folder and its missing parents; returns the folders created, outermost first."""
    missing = []
    for candidate in (folder, *folder.parents):
        if candidate.is_dir():
            break
        if candidate.exists() or candidate.is_symlink():
            raise SigncastError(f"cannot create folder {shown}: {candidate} is a file, not a folder")
        missing.append(candidate)
    made = []
    try:
        for path in reversed(missing):
            path.mkdir()
            made.append(path)
    except OSError as error:
        _remove_folders(made)
        raise SigncastError(f"cannot create folder {shown}: {_reason(error)}") from None
    return made


def _remove_folders(folders: Iterable[Path]) -> None:
    """Remove folders, innermost first, if they are empty."""
    for folder in sorted(folders, key=lambda p: len(p.parts), reverse=True):
        try:
            folder.rmdir()
        except OSError:
            pass


def _remove_owned(folder: Path) -> None:
    """Remove the files an earlier run listed in folder's manifest, and the folders that leaves empty."""
    manifest = folder / MANIFEST
    if not manifest.is_file():
        return
    root = folder.resolve()
    emptied = set()
    for line in manifest.read_text(encoding="utf-8").splitlines():
        path = (folder / line).resolve()
        if not line.strip() or root not in path.parents or not path.is_file():   # never leave the folder
            continue
        path.unlink(missing_ok=True)
        emptied.update(p for p in path.parents if root in p.parents)
    manifest.unlink()
    _remove_folders(emptied)


def _owned(folder: Path) -> set[Path]:
    """The files an earlier run listed in folder's MANIFEST (the manifest included); empty without one."""
    manifest = folder / MANIFEST
    if not manifest.is_file():
        return set()
    try:
        lines = manifest.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError):
        return set()
    return {(folder / line).resolve() for line in lines if line.strip()} | {manifest.resolve()}


def check_folder(folder: Path, *, force: bool = False, resumable: bool = False) -> None:
    """Refuse, before anything is created, an --out that is a file, or a non-empty folder without --force
    (resumable: a folder holding only what an earlier signcast run listed in MANIFEST is accepted, for `sweep`,
    which resumes in place)."""
    if folder.exists() and not folder.is_dir():
        raise SigncastError(f"--out {folder} is a file, not a folder: choose a folder")
    if resumable and folder.is_dir() and not force:
        owned = _owned(folder)
        if any(path.resolve() not in owned for path in _files(folder)):
            raise SigncastError(f"--out {folder} is not empty and holds files signcast did not write: choose a new "
                                f"or empty folder, or pass --force")
        return
    if folder.is_dir() and not force and any(folder.iterdir()):
        raise SigncastError(f"--out {folder} is not empty: choose a new or empty folder, or pass --force to replace "
                            f"the files of the same names and those an earlier signcast run wrote there")


def _partial_folder(folder: Path) -> Path:
    """A new, empty folder beside folder (made with the umask's permissions, unlike mkdtemp's 0700)."""
    for attempt in range(1000):
        candidate = folder.parent / (f".{folder.name}{PARTIAL}{os.getpid()}" + (f"-{attempt}" if attempt else ""))
        try:
            candidate.mkdir()
            return candidate
        except FileExistsError:
            continue
    raise FileExistsError(f"too many {PARTIAL} folders beside {folder}")


def _move_into(source: Path, target: Path) -> None:
    """Every file below source moved to the same place below target (folders made, same-named files replaced)."""
    for entry in source.iterdir():
        destination = target / entry.name
        if entry.is_dir() and not entry.is_symlink():
            if destination.is_dir() and not destination.is_symlink():
                _move_into(entry, destination)
                continue
            if destination.exists() or destination.is_symlink():
                destination.unlink()
        elif destination.is_dir() and not destination.is_symlink():
            shutil.rmtree(destination)
        os.replace(entry, destination)


@contextmanager
def output_folder(folder: str | Path, *, force: bool = False) -> Iterator[Path]:
    """A temporary folder beside the checked --out folder, to write one run's results into; moved into place when
    the run succeeds, removed when it fails (see the module's policy). Use the folder it yields, not --out."""
    folder = Path(folder)
    check_folder(folder, force=force)
    existed = folder.is_dir()
    created = [] if existed else _make_folder(folder.parent, folder)
    if existed:
        _probe(folder, folder)
    try:
        partial = _partial_folder(folder.resolve())
    except OSError as error:
        _remove_folders(created)
        what = f"cannot write beside {folder}" if existed else f"cannot create folder {folder}"
        raise SigncastError(f"{what}: {_reason(error)}") from None
    try:
        yield partial
        _write_manifest(partial)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        _remove_folders(created)
        raise
    try:
        if not existed:
            os.replace(partial, folder)
            return
        _remove_owned(folder)
        _move_into(partial, folder.resolve())
    finally:
        shutil.rmtree(partial, ignore_errors=True)


def _write_manifest(folder: Path) -> None:
    """List in MANIFEST every file below folder."""
    written = sorted(path.relative_to(folder).as_posix() for path in _files(folder) if path.name != MANIFEST)
    (folder / MANIFEST).write_text("".join(f"{name}\n" for name in written), encoding="utf-8")


def check_file(path: Path, what: str, suffixes: tuple[str, ...] = (), *, force: bool = False) -> None:
    """Refuse, before the work, an output file that cannot be written: a folder, a wrong suffix, a missing or
    unwritable folder, an existing file without force. Creates nothing: a probe file made to check is removed
    again."""
    if suffixes and path.suffix.lower() not in suffixes:
        raise SigncastError(f"cannot write {what} {path}: the name must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise SigncastError(f"cannot write {what} {path}: it is a folder")
    if (path.exists() or path.is_symlink()) and not force:
        raise SigncastError(f"{what} {path} exists: choose another name, or pass --force to replace it")
    folder = path.parent
    if not folder.is_dir():
        raise SigncastError(f"cannot write {what} {path}: folder {folder} does not exist")
    try:
        if path.exists():
            with path.open("ab"):
                pass
        else:
            with path.open("xb"):
                pass
            path.unlink()
    except OSError as error:
        raise SigncastError(f"cannot write {what} {path}: {_reason(error)}") from None


@contextmanager
def output_files(*files: tuple[Path | None, str] | tuple[Path | None, str, tuple[str, ...]],
                 force: bool = False) -> Iterator[None]:
    """Check each (path, what[, suffixes]) with check_file (None: not asked for; an existing file only with force);
    if the run fails, remove the files it created."""
    wanted = [(Path(spec[0]), *spec[1:]) for spec in files if spec[0] is not None]
    for spec in wanted:
        check_file(*spec, force=force)
    new = [spec[0] for spec in wanted if not spec[0].exists()]
    try:
        yield
    except BaseException:
        for path in new:
            path.unlink(missing_ok=True)
        raise


def add_force_argument(parser, files: bool = False) -> None:
    """The `--force` option of every command that writes an --out folder (files: or output files)."""
    if files:
        parser.add_argument("--force", action="store_true", help="replace output files that exist already")
        return
    parser.add_argument("--force", action="store_true",
                        help=f"write into a non-empty --out folder once the run succeeds: the files an earlier "
                             f"signcast run wrote there (listed in {MANIFEST}) are removed and files of the same "
                             f"names replaced; other files are kept")


# ------------------------------------------------------------------------------------------------------------
# writing: the only place files are written from what comparisons/ returns (text, bytes, rows, figures, records)

def write_text(path: str | Path, text: str) -> Path:
    """text written to path as UTF-8 (folders made); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def write_bytes(path: str | Path, data: bytes) -> Path:
    """data written to path (folders made); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


def write_rows(path: str | Path, rows: list[list]) -> Path:
    """rows (the header first) written as CSV; returns the path."""
    import csv
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as handle:
        csv.writer(handle).writerows(rows)
    return path


def write_dicts(path: str | Path, rows: list[dict], fieldnames: list[str] | None = None) -> Path:
    """rows (dicts) written as CSV with a header (fieldnames, or the first row's keys); returns the path."""
    import csv
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=fieldnames or (list(rows[0]) if rows else []))
        writer.writeheader()
        writer.writerows(rows)
    return path


def save_figure(figure, path: str | Path, **options) -> Path:
    """A matplotlib figure saved as PNG (options: savefig's, e.g. dpi) and closed; returns the path."""
    import matplotlib.pyplot as plt
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        figure.savefig(path, **options)
    finally:
        plt.close(figure)
    return path


def write_records(path: str | Path, records: list, *, append: bool = False) -> Path:
    """Records (comparisons.reports.records.Record or dicts) written as JSON lines
    (comparisons.reports.records.records_text); append: added to the end of the file, closed (so flushed) on
    return, so an interrupted run keeps them. A record the schema rejects raises SigncastError, nothing written."""
    from comparisons.reports.records import records_text
    path = Path(path)
    text = records_text(records, where=str(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a" if append else "w", encoding="utf-8") as handle:
        handle.write(text)
    return path


def write_outputs(folder: str | Path, outputs: dict) -> list[Path]:
    """Each of outputs (file name -> str: text, bytes, a list of CSV rows with the header first, or a matplotlib
    figure: PNG at the figure's dpi) written under folder; returns the paths in outputs' order."""
    folder = Path(folder)
    written = []
    for name, content in outputs.items():
        path = folder / name
        if isinstance(content, str):
            written.append(write_text(path, content))
        elif isinstance(content, (bytes, bytearray)):
            written.append(write_bytes(path, bytes(content)))
        elif isinstance(content, list):
            written.append(write_rows(path, content))
        else:
            written.append(save_figure(content, path))
    return written


def build_report(records: list, out_path: str | Path, *, poster_png: bytes | None = None, **options) -> Path:
    """The comparison's HTML report (comparisons.reports.comparison.report_html) written to out_path; returns it.
    SigncastError when the records hold no measured point."""
    from comparisons.reports.comparison import report_html
    return write_text(out_path, report_html(records, poster_png=poster_png, **options))
