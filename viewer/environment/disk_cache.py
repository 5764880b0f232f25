"""The on-disk cache of environment precomputation: what
:class:`viewer.environment.store.EnvironmentStore` computes for an environment (the loaded image, its sun, the convolved prefiltered levels, SH
coefficients, equal-power directions, later its importance-sampling tables; the DFG LUTs once), so
the same file in a new process skips the file's decoding and every CPU and GPU precomputation.

Where: ``$RELIGHT_CACHE_DIR/environments``, else ``$XDG_CACHE_HOME/relight/environments``, else
``~/.cache/relight/environments``. ``RELIGHT_ENV_CACHE=0`` (or ``off``, ``false``, ``no``) turns it
off; tests do. ``RELIGHT_ENV_CACHE_MB`` caps its size (default 2048 MiB): after each write the
least recently used entries (by file modification time; a hit touches its files) are deleted until
the folder fits.

Entries are keyed by the source's content (a file's BLAKE2b digest, or a procedural environment's
parameters) and the IBL options; each part is one ``<key>.<part>.safetensors`` file (no pickle)
whose JSON metadata holds the format version, the key, per-array CRC-32 checksums and the part's
own fields. An entry that cannot be read, is truncated, fails a checksum, has the wrong shapes or
another format version is never used: it is deleted and rebuilt, with a one-line warning naming
the file.
"""
from __future__ import annotations

import hashlib
import json
import os
import warnings
import zlib
from pathlib import Path

import numpy as np

# Bump when what an entry holds or how it is computed changes (the loader's resampling, the
# convolution, the sun extraction, the sampling tables): older entries are then stale.
FORMAT = 4  # 2: the irradiance maps, several lights per environment; 3: 512-wide irradiance;
# 4: compact cores of too-large bright regions become lights (sun.py SUN_CORE_FRACTION)
DEFAULT_MAX_BYTES = 2048 << 20
_SUFFIX = ".safetensors"
_OFF = ("0", "off", "false", "no")


def cache_root() -> Path:
    """The relight cache folder (see the module docstring for the variables it reads)."""
    root = os.environ.get("RELIGHT_CACHE_DIR")
    if root:
        return Path(root).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "relight"


def file_digest(path: str | os.PathLike, _memo: dict = {}) -> str:  # noqa: B006 - the memo
    """BLAKE2b (128-bit) hex digest of a file's bytes; remembered per (path, size, mtime) in this
    process, so a file is read once however often its key is asked for."""
    p = Path(path)
    st = p.stat()
    memo_key = (str(p.resolve()), st.st_size, st.st_mtime_ns)
    if memo_key not in _memo:
        h = hashlib.blake2b(digest_size=16)
        with open(p, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 22), b""):
                h.update(chunk)
        _memo[memo_key] = h.hexdigest()
    return _memo[memo_key]


def digest_key(*parts) -> str:
    """A cache key: the SHA-256 (128 bits, hex) of the JSON of ``parts``."""
    text = json.dumps(parts, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


class EnvCache:
    """A folder of cached environment parts, capped at ``max_bytes`` (LRU by mtime)."""

    def __init__(self, root: str | os.PathLike, max_bytes: int = DEFAULT_MAX_BYTES):
        if max_bytes < 0:
            raise ValueError(f"environment cache cap must be >= 0 bytes, got {max_bytes}")
        self.root = Path(root)
        self.max_bytes = int(max_bytes)
        self.hits = self.misses = self.writes = self.rejected = 0
        self._known_bytes: int | None = None  # the folder's size at the last trim (stats())

    @classmethod
    def from_environment(cls) -> "EnvCache | None":
        """The user's cache (``cache_root() / "environments"``), or None where
        ``RELIGHT_ENV_CACHE`` turns it off. A bad ``RELIGHT_ENV_CACHE_MB`` is a one-line error."""
        if os.environ.get("RELIGHT_ENV_CACHE", "1").strip().lower() in _OFF:
            return None
        mb = os.environ.get("RELIGHT_ENV_CACHE_MB")
        max_bytes = DEFAULT_MAX_BYTES
        if mb is not None:
            try:
                max_bytes = int(float(mb) * (1 << 20))
            except ValueError:
                raise ValueError(f"RELIGHT_ENV_CACHE_MB must be a number of MiB, got {mb!r}") \
                    from None
        return cls(cache_root() / "environments", max_bytes)

    def path(self, key: str, part: str) -> Path:
        return self.root / f"{key}.{part}{_SUFFIX}"

    # ---- reading ----------------------------------------------------------------------------
    def load(self, key: str, part: str, expect: dict | None = None
             ) -> tuple[dict[str, np.ndarray], dict] | None:
        """``(arrays, meta)`` of a stored part, or None (a miss). A part that is unreadable,
        truncated, of another format or key, fails a checksum, or whose arrays differ from
        ``expect`` (name -> shape, ``None`` for any shape; listed names must be present) is
        deleted with a one-line warning and reported as a miss."""
        path = self.path(key, part)
        if not path.exists():
            self.misses += 1
            return None
        try:
            from safetensors import safe_open

            with safe_open(str(path), framework="np") as f:
                header = f.metadata() or {}
                arrays = {name: f.get_tensor(name) for name in f.keys()}
        except Exception as exc:  # noqa: BLE001 - any unreadable file is a miss, never trusted
            return self._reject(path, f"unreadable or truncated ({_one_line(exc)})")
        problem = self._check(header, key, part, arrays, expect)
        if problem:
            return self._reject(path, problem)
        try:
            os.utime(path)  # most recently used
        except OSError:
            pass
        self.hits += 1
        return arrays, json.loads(header.get("meta", "{}"))

    @staticmethod
    def _check(header: dict, key: str, part: str, arrays: dict, expect: dict | None) -> str:
        try:
            fmt = int(header.get("format", "-1"))
            crcs = json.loads(header.get("crc", "{}"))
            json.loads(header.get("meta", "{}"))
        except ValueError:
            return "corrupt metadata"
        if fmt != FORMAT:
            return f"stale (format {fmt}, this version reads {FORMAT})"
        if header.get("key") != key or header.get("part") != part:
            return "holds another entry"
        if set(crcs) != set(arrays):
            return "array list does not match its checksums"
        for name, arr in arrays.items():
            if zlib.crc32(np.ascontiguousarray(arr)) != int(crcs[name]):
                return f"checksum mismatch in {name!r}"
        for name, shape in (expect or {}).items():
            if name not in arrays:
                return f"missing {name!r}"
            if shape is not None and tuple(arrays[name].shape) != tuple(shape):
                return f"{name!r} has shape {tuple(arrays[name].shape)}, expected {tuple(shape)}"
        return ""

    def reject(self, key: str, part: str, reason: str) -> None:
        """Delete a part the caller found unusable (one-line warning naming the file)."""
        self._reject(self.path(key, part), reason)

    def _reject(self, path: Path, reason: str):
        self.rejected += 1
        self.misses += 1
        warnings.warn(f"{path}: environment cache entry {reason}; rebuilding it", stacklevel=3)
        try:
            path.unlink()
        except OSError:
            pass
        return None

    # ---- writing ----------------------------------------------------------------------------
    def save(self, key: str, part: str, arrays: dict[str, np.ndarray], meta: dict) -> None:
        """Store a part (atomically: a temporary file renamed over the old one), then trim the
        folder to its cap. A folder that cannot be written is a one-line warning, not an error:
        the cache is an optimisation."""
        from safetensors.numpy import save_file

        arrays = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
        header = {"format": str(FORMAT), "key": key, "part": part,
                  "meta": json.dumps(meta, sort_keys=True),
                  "crc": json.dumps({k: zlib.crc32(v) for k, v in arrays.items()})}
        path = self.path(key, part)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            self.root.mkdir(parents=True, exist_ok=True)
            save_file(arrays, str(tmp), metadata=header)
            os.replace(tmp, path)
        except OSError as exc:
            warnings.warn(f"{self.root}: cannot write the environment cache ({_one_line(exc)})",
                          stacklevel=2)
            return
        finally:
            if tmp.exists():
                tmp.unlink()
        self.writes += 1
        self.trim()

    def entries(self) -> list[tuple[float, int, list[Path]]]:
        """``(last use, bytes, files)`` per key, least recently used first."""
        groups: dict[str, list[Path]] = {}
        if not self.root.is_dir():
            return []
        for p in self.root.glob(f"*{_SUFFIX}"):
            groups.setdefault(p.name.split(".", 1)[0], []).append(p)
        out = []
        for files in groups.values():
            stats = []
            for p in files:
                try:
                    stats.append(p.stat())
                except OSError:  # removed by another process meanwhile
                    continue
            if stats:
                out.append((max(s.st_mtime for s in stats), sum(s.st_size for s in stats), files))
        return sorted(out, key=lambda e: e[0])

    @property
    def bytes(self) -> int:
        return sum(e[1] for e in self.entries())

    def trim(self) -> int:
        """Delete least recently used entries until the folder is within the cap; returns how
        many entries were deleted."""
        entries = self.entries()
        total = sum(e[1] for e in entries)
        removed = 0
        for _, size, files in entries:
            if total <= self.max_bytes:
                break
            for p in files:
                try:
                    p.unlink()
                except OSError:
                    pass
            total -= size
            removed += 1
        self._known_bytes = total
        return removed

    def stats(self) -> dict:
        """Counts and the folder's size (as of the last write; scanned once before any)."""
        if self._known_bytes is None:
            self._known_bytes = self.bytes
        return {"root": str(self.root), "bytes": self._known_bytes, "max_bytes": self.max_bytes,
                "hits": self.hits, "misses": self.misses, "writes": self.writes,
                "rejected": self.rejected}


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())[:200] or type(exc).__name__
