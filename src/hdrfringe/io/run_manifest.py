"""Content hashes of files and folders, and the per-stage manifests of ``hdrfringe run``.

A stage of a project run (docs/project_file.md) is skipped when nothing it depends on
changed. What it depended on when it last ran is recorded in a small strict-JSON manifest
(``OUT/manifests/<stage>.json``): the key (a digest of its options, the content hashes of its
input files and its upstream stages' output hashes) and every output file with its size,
modification time and SHA-256. :func:`tree_files` hashes a file or a folder's files;
:func:`output_problem` checks a recorded output without reading unchanged files (a file whose
size and modification time are as recorded is taken as unchanged, as ``git status`` does; any
other is hashed again).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from hdrfringe.core import strict_json
from hdrfringe.io.results import staged_output_file

__all__ = [
    "MANIFEST_FORMAT",
    "digest",
    "file_sha256",
    "output_problem",
    "read_manifest",
    "tree_files",
    "write_json",
]

#: ``format`` of a stage manifest; a manifest of another format or version is not trusted.
MANIFEST_FORMAT = {"format": "hdrfringe-stage-manifest", "version": 1}
_CHUNK = 1 << 20


def file_sha256(path: str | Path) -> str:
    """SHA-256 of a file's bytes.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    str
        64 hex digits.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "a.txt"
    >>> _ = p.write_bytes(b"abc")
    >>> file_sha256(p)[:16]
    'ba7816bf8f01cfea'
    """
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(_CHUNK):
            h.update(chunk)
    return h.hexdigest()


def _files(path: Path) -> list[tuple[str, Path]]:
    """(relative name, path) of ``path`` itself (a file: name "") or of every file under it."""
    if not path.is_dir():
        return [("", path)]
    out = []
    for folder, dirs, names in os.walk(path):
        dirs.sort()
        for name in sorted(names):
            full = Path(folder) / name
            out.append((full.relative_to(path).as_posix(), full))
    return sorted(out)


def tree_files(path: str | Path) -> dict[str, list[Any]]:
    """Every file of a file or folder with its size, modification time and content hash.

    Parameters
    ----------
    path : str or Path
        A file (one entry, named ``""``) or a folder (its files, recursively, by relative
        POSIX path).

    Returns
    -------
    dict
        Name -> ``[size, mtime_ns, sha256]``, sorted by name.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> (root / "sub").mkdir()
    >>> _ = (root / "sub" / "b.txt").write_bytes(b"abc")
    >>> files = tree_files(root)
    >>> list(files), files["sub/b.txt"][0]
    (['sub/b.txt'], 3)
    """
    out: dict[str, list[Any]] = {}
    for name, full in _files(Path(path)):
        st = full.stat()
        out[name] = [st.st_size, st.st_mtime_ns, file_sha256(full)]
    return out


def digest(files: Mapping[str, list[Any]]) -> str:
    """The content hash of a tree: its file names and their SHA-256 (not sizes or times).

    Parameters
    ----------
    files : mapping
        :func:`tree_files`.

    Returns
    -------
    str
        64 hex digits; equal for trees of equal names and contents wherever they are.

    Examples
    --------
    >>> digest({"a": [3, 1, "x"]}) == digest({"a": [3, 2, "x"]}) != digest({"b": [3, 1, "x"]})
    True
    """
    h = hashlib.sha256()
    for name in sorted(files):
        h.update(f"{name}\0{files[name][2]}\n".encode())
    return h.hexdigest()


def output_problem(path: str | Path, files: Mapping[str, list[Any]]) -> str | None:
    """What is wrong with a stage's output against its record, or None when it is intact.

    A recorded file that is missing, of another size, or (when its modification time
    changed) of other content is a problem; a file of the same size and time is taken as
    unchanged without reading it. Files added beside the recorded ones are not.

    Parameters
    ----------
    path : str or Path
        The output (file or folder).
    files : mapping
        Its record (:func:`tree_files` when it was written).

    Returns
    -------
    str or None
        E.g. ``"metrics.json is missing"``.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> _ = (root / "a.txt").write_text("abc")
    >>> record = tree_files(root)
    >>> output_problem(root, record) is None
    True
    >>> _ = (root / "a.txt").write_text("abd")
    >>> output_problem(root, {**record, "b.txt": [1, 0, "0"]})
    'a.txt changed'
    """
    root = Path(path)
    if not files:
        return "nothing recorded"
    for name, (size, mtime_ns, sha) in sorted(files.items()):
        full = root / name if name else root
        try:
            st = full.stat()
        except OSError:
            return f"{name or root.name} is missing"
        if not full.is_file() or st.st_size != size:
            return f"{name or root.name} changed"
        if st.st_mtime_ns != mtime_ns and file_sha256(full) != sha:
            return f"{name or root.name} changed"
    return None


def read_manifest(path: str | Path) -> dict[str, Any] | None:
    """A stage manifest, or None when there is none or it cannot be trusted.

    A missing, unreadable, malformed or foreign file, or one without its output record
    (``output.sha256`` and ``output.files``), reads as None: the stage then runs again (its
    output is rewritten), which is always safe.

    Parameters
    ----------
    path : str or Path
        ``OUT/manifests/<stage>.json``.

    Returns
    -------
    dict or None

    Examples
    --------
    >>> read_manifest("/nonexistent/manifest.json") is None
    True
    """
    from hdrfringe.errors import HdrFringeError
    from hdrfringe.io._read_limits import load_json_bounded

    try:
        data = load_json_bounded(Path(path))
    except (OSError, ValueError, HdrFringeError):  # unreadable: simply not trusted
        return None
    if not isinstance(data, dict) or any(data.get(k) != v for k, v in MANIFEST_FORMAT.items()):
        return None
    output = data.get("output")
    if not isinstance(output, dict) or not isinstance(output.get("sha256"), str):
        return None
    files = output.get("files")
    if not isinstance(files, dict) or not all(
        isinstance(v, list) and len(v) == 3 for v in files.values()
    ):
        return None
    return data


def write_json(path: str | Path, data: Mapping[str, Any]) -> None:
    """Write strict JSON (non-finite refused) to a file, staged: complete or not at all.

    Parameters
    ----------
    path : str or Path
        The file (replaced if it exists).
    data : mapping
        What to write.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "m.json"
    >>> write_json(p, {"a": 1})
    >>> p.read_text()
    '{\\n "a": 1\\n}\\n'
    """
    text = strict_json.dumps(data, nonfinite="error") + "\n"
    with staged_output_file(path, force=True) as tmp:
        tmp.write_text(text, encoding="utf-8")
