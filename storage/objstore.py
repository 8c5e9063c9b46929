"""Stores on object storage: where a store argument names a bucket (``s3://bucket/prefix/name.zarr``).

A store argument is a plain path, a ``file://`` URL (the same as the plain path: the local store of
:mod:`storage.store`, byte for byte) or an ``s3://`` URL, read and written through zarr v3's
:class:`~zarr.storage.FsspecStore` on an asynchronous s3fs file system (zarr-python #2554 / dask #11691: the
file system must be async).

Credentials and endpoint come from where boto looks (``AWS_ACCESS_KEY_ID``, ``AWS_SECRET_ACCESS_KEY``,
``AWS_ENDPOINT_URL_S3`` / ``AWS_ENDPOINT_URL``, ``~/.aws``), or from ``--storage-option KEY=VALUE``: those are
kept in this process's environment (``SVGEN_STORAGE_OPTIONS``, JSON) so that local dask worker processes inherit
them, and are never written into a store's attributes, its configuration or its hash. Workers on other machines
take their credentials from their own environment.

Timeouts are short and retries few (:data:`DEFAULT_OPTIONS`), so an unreachable endpoint is one line after a few
seconds, never a hang. Every failure of the object store becomes one :class:`~svcore.errors.StoreError` line
(:func:`s3_errors`).
"""
from __future__ import annotations

import atexit
import hashlib
import json
import os
import re
import threading
import warnings
from contextlib import contextmanager
from pathlib import Path

from svcore.errors import StoreError

#: the schemes a store argument may use; anything else written as ``scheme://`` is refused (a typo, or a backend
#: this project does not test).
OBJECT_SCHEMES = ("s3",)
LOCAL_SCHEMES = ("file",)
OPTIONS_ENV = "SVGEN_STORAGE_OPTIONS"
CACHE_ENV = "SVGEN_OBJECT_CACHE"
_URL = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*)://(.*)$")

#: s3fs options used unless given: connect and read timeouts of a few seconds and two attempts, so that an
#: unreachable endpoint fails in seconds (botocore's defaults: 60 s timeouts, retried).
DEFAULT_OPTIONS = {"config_kwargs": {"connect_timeout": 3, "read_timeout": 20, "retries": {"max_attempts": 2}}}
#: s3fs's own retry loop around every call (its default: 5 with back-off)
S3FS_RETRIES = 2


#: the suffix of a store being written (renamed onto the final name when complete)
PARTIAL_SUFFIX = ".partial"


def partial_path(path: str | os.PathLike) -> Path:
    """The ``.partial`` sibling a local store is written in before it is complete."""
    p = Path(local_path(path))
    return p.with_name(p.name + PARTIAL_SUFFIX)


def scheme(path) -> str | None:
    """The URL scheme of a store argument (lower case), or None for a plain path."""
    m = _URL.match(str(path))
    return m.group(1).lower() if m else None


def is_object_url(path) -> bool:
    """Whether ``path`` names a store on object storage (``s3://…``).

    Raises:
        StoreError: ``scheme://`` with a scheme that is neither an object store nor ``file``.
    """
    s = scheme(path)
    if s is None or s in LOCAL_SCHEMES:
        return False
    if s in OBJECT_SCHEMES or s == "s3a":
        return True
    raise StoreError(f"unknown storage scheme {s!r} in {path!r}: a store is a plain path, file://PATH or "
                     "s3://BUCKET/PREFIX/NAME.zarr")


def local_path(path) -> str:
    """A plain path for a local store argument (``file://`` stripped)."""
    p = str(path)
    return p[len("file://"):] if scheme(p) == "file" else p


def normalize_url(url: str) -> str:
    """``s3://bucket/prefix/name.zarr`` without trailing slash; credentials in the URL are refused."""
    m = _URL.match(str(url))
    rest = m.group(2).strip("/")
    bucket = rest.split("/", 1)[0]
    if "@" in bucket or ":" in bucket:
        raise StoreError(f"{scheme(url)}:// store URL {url!r} carries credentials or a port: give credentials "
                         "through AWS_* variables or --storage-option, the endpoint through AWS_ENDPOINT_URL")
    if not bucket or "/" not in rest:
        raise StoreError(f"store URL {url!r} names no store inside the bucket: use s3://BUCKET/NAME.zarr")
    return f"s3://{rest}"


# -- storage options ---------------------------------------------------------------------------------------------
def parse_storage_options(pairs) -> dict:
    """``KEY=VALUE`` strings (VALUE read as YAML; dotted keys nest: ``client_kwargs.region_name=eu-west-1``).

    Raises:
        StoreError: a pair without ``=``.
    """
    import yaml

    out: dict = {}
    for pair in pairs or ():
        key, eq, value = str(pair).partition("=")
        if not eq or not key.strip():
            raise StoreError(f"--storage-option {key!r} must be KEY=VALUE (e.g. endpoint_url=http://127.0.0.1:9000)")
        try:
            v = yaml.safe_load(value) if value else ""
        except yaml.YAMLError:
            v = value
        d = out
        parts = key.strip().split(".")
        for p in parts[:-1]:
            d = d.setdefault(p, {})
        d[parts[-1]] = v
    return out


def set_storage_options(pairs) -> None:
    """Make ``--storage-option`` pairs this process's (and its local workers') object-store options."""
    opts = parse_storage_options(pairs)
    if opts:
        os.environ[OPTIONS_ENV] = json.dumps(_merge(_env_options(), opts))


def _env_options() -> dict:
    raw = os.environ.get(OPTIONS_ENV)
    if not raw:
        return {}
    try:
        v = json.loads(raw)
    except ValueError:
        raise StoreError(f"{OPTIONS_ENV} is not JSON") from None
    return v if isinstance(v, dict) else {}


def _merge(a: dict, b: dict) -> dict:
    out = dict(a)
    for k, v in b.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def storage_options() -> dict:
    """The s3fs options in force: defaults < endpoint from ``AWS_ENDPOINT_URL(_S3)`` < ``--storage-option``."""
    opts = _merge({}, DEFAULT_OPTIONS)
    ep = os.environ.get("AWS_ENDPOINT_URL_S3") or os.environ.get("AWS_ENDPOINT_URL")
    if ep:
        opts["endpoint_url"] = ep
    return _merge(opts, _env_options())


def _endpoint() -> str:
    return str(storage_options().get("endpoint_url") or "the default AWS endpoint")


# -- errors ------------------------------------------------------------------------------------------------------
def _one_line(e: object) -> str:
    return " ".join(str(e).split())


@contextmanager
def s3_errors(url: str, doing: str = "access"):
    """Turn what s3fs/botocore/aiohttp raise into one StoreError line naming the store and the endpoint."""
    try:
        yield
    except StoreError:
        raise
    except FileExistsError:
        raise
    except Exception as e:  # noqa: BLE001 - the object store's failures have many types; each becomes one line
        raise StoreError(describe_failure(e, url, doing)) from None


def describe_failure(e: BaseException, url: str, doing: str = "access") -> str:
    """One line for an object-store failure."""
    text = _one_line(e)
    low = text.lower()
    bucket = url.split("://", 1)[-1].split("/", 1)[0]
    if "nosuchbucket" in low or "bucket does not exist" in low:
        return f"cannot {doing} {url}: bucket {bucket!r} does not exist at {_endpoint()}"
    if isinstance(e, PermissionError) or any(s in low for s in ("accessdenied", "access denied", "invalidaccesskeyid",
                                                                 "signaturedoesnotmatch", "forbidden",
                                                                 "unable to locate credentials")):
        return (f"cannot {doing} {url}: access denied at {_endpoint()} ({text}); check AWS_ACCESS_KEY_ID / "
                "AWS_SECRET_ACCESS_KEY or --storage-option key=… secret=…")
    if any(s in low for s in ("could not connect", "connect timeout", "cannot connect", "connection refused",
                              "endpoint url", "timed out", "name or service not known")) or \
            type(e).__name__ in ("EndpointConnectionError", "ConnectTimeoutError", "ClientConnectorError"):
        return f"cannot {doing} {url}: the object store endpoint {_endpoint()} is unreachable ({text})"
    return f"cannot {doing} {url}: {type(e).__name__}: {text}"


# -- one store's location ----------------------------------------------------------------------------------------
class ObjectLocation:
    """A store prefix in a bucket and the operations the commit protocol needs (all keys relative to the store).

    Args:
        url: ``s3://bucket/prefix/name.zarr``.
    """

    def __init__(self, url: str):
        self.url = normalize_url(url)
        self.root = self.url.split("://", 1)[1]  # bucket/prefix/name.zarr
        self.bucket = self.root.split("/", 1)[0]
        self._fs = None

    def __str__(self) -> str:
        return self.url

    @property
    def fs(self):
        """A synchronous s3fs for the protocol's small objects (markers, lock, manifest, listings)."""
        if self._fs is None:
            self._fs = make_fs(asynchronous=False)
        return self._fs

    def key(self, rel: str = "") -> str:
        return f"{self.root}/{rel}" if rel else self.root

    def sibling(self, suffix: str) -> str:
        """Key of an object beside the store (``name.zarr.lock``)."""
        return self.root + suffix

    def zarr_store(self, read_only: bool, cached: bool = False, cache_tag: str = ""):
        """zarr's FsspecStore on this prefix (async s3fs), read through a local disk cache if ``cached``.

        ``cache_tag`` names the content (the manifest's hash): a store rewritten under the same URL never reads
        another's cached chunks.
        """
        store = fork_safe_store(lambda: make_fs(asynchronous=True), self.root, read_only)
        if cached and os.environ.get(CACHE_ENV, "") != "off":
            base = os.environ.get(CACHE_ENV) or str(Path.home() / ".cache" / "svgen" / "objects")
            tag = hashlib.sha256(f"{self.url}\0{cache_tag}".encode()).hexdigest()[:24]
            return disk_cached(store, Path(base) / tag)
        return store

    # small objects
    def exists(self, rel: str) -> bool:
        return self.fs.exists(self.key(rel))

    def read(self, rel: str) -> bytes:
        return self.fs.cat_file(self.key(rel))

    def read_or_none(self, rel: str) -> bytes | None:
        try:
            return self.fs.cat_file(self.key(rel))
        except FileNotFoundError:
            return None

    def write(self, rel_or_key: str, data: bytes, absolute: bool = False) -> None:
        self.fs.pipe_file(rel_or_key if absolute else self.key(rel_or_key), data)

    def create_exclusive(self, key: str, data: bytes) -> bool:
        """Create ``key`` only if no object has that name (S3 conditional put ``If-None-Match: *``).

        Returns:
            False where an object already exists.
        """
        try:
            self.fs.pipe_file(key, data, mode="create")
            return True
        except FileExistsError:
            return False

    def delete(self, key: str) -> None:
        try:
            self.fs.rm_file(key)
        except FileNotFoundError:
            pass

    def delete_tree(self) -> None:
        self.fs.invalidate_cache(self.root)
        keys = list(self.sizes().keys())
        if keys:
            self.fs.rm([self.key(k) for k in keys])

    def sizes(self, rel: str = "") -> dict[str, int]:
        """Every object under the store (or under ``rel`` in it): relative key -> size; one listing."""
        base = self.key(rel)
        self.fs.invalidate_cache(base)
        try:
            found = self.fs.find(base, detail=True)
        except FileNotFoundError:
            return {}
        n = len(self.root) + 1
        return {k[n:]: int(v.get("size") or 0) for k, v in found.items() if k.startswith(self.root + "/")}

    def check_bucket(self, doing: str) -> None:
        """Refuse a missing bucket with one line (before anything is written)."""
        with s3_errors(self.url, doing):
            try:
                self.fs.ls(self.bucket, refresh=True)
            except FileNotFoundError:
                raise StoreError(f"cannot {doing} {self.url}: bucket {self.bucket!r} does not exist at "
                                 f"{_endpoint()}") from None


def zarr_location(path, read_only: bool = True):
    """What ``zarr.open_group`` should open for a store argument: the plain path of a local store, or the
    FsspecStore of an ``s3://`` store built with :func:`storage_options` (a bare URL handed to zarr would use
    fsspec's defaults and miss ``--storage-option``)."""
    return ObjectLocation(str(path)).zarr_store(read_only=read_only) if is_object_url(path) else local_path(path)


def _s3fs_options() -> dict:
    return {k: v for k, v in storage_options().items()}


def make_fs(asynchronous: bool):
    """A new s3fs file system with :func:`storage_options` (not fsspec's instance cache: options may change)."""
    try:
        import s3fs
    except ImportError as e:
        raise StoreError(f"s3:// stores need s3fs (pip install 'svgen[s3]'): {e}") from None
    _quiet()
    # fsspec's instance cache: one client (and one aiohttp session) per process, options and thread; it is
    # dropped in a forked child. New instances per call would leave unclosed sessions that asyncio reports.
    fs = s3fs.S3FileSystem(asynchronous=asynchronous, **_s3fs_options())
    fs.retries = S3FS_RETRIES
    if asynchronous and fs not in _ASYNC_FS:
        _ASYNC_FS.append(fs)
    return fs


#: the async file systems zarr uses in this process: their sessions live in zarr's event loop, and nothing closes
#: them (s3fs closes only its sync instances' sessions), so asyncio would report "Unclosed client session" at exit
_ASYNC_FS: list = []


def _close_async_sessions() -> None:
    if not _ASYNC_FS:  # nothing opened: importing zarr at exit would fail ("can't register atexit after shutdown")
        return
    from zarr.core.sync import sync

    for fs in _ASYNC_FS:
        client = getattr(fs, "_s3", None)
        if client is not None:
            try:
                sync(client.close())
            except Exception:  # noqa: BLE001 - exiting anyway
                pass
    _ASYNC_FS.clear()


atexit.register(_close_async_sessions)


def _quiet() -> None:
    """boto narrates credential lookups at INFO: keep its warnings unless svgen runs with --verbose."""
    import logging

    if not logging.getLogger("pipeline").isEnabledFor(logging.DEBUG):
        for name in ("aiobotocore", "botocore", "s3fs", "fsspec"):
            logging.getLogger(name).setLevel(logging.WARNING)


def disk_cached(store, cache_dir: Path):
    """A read-only zarr store that keeps every whole object it reads from ``store`` as a file in ``cache_dir``.

    For complete stores only (their objects never change; the directory is named after the manifest). Each file
    is written under a temporary name and renamed, so processes sharing the directory (torch loader workers,
    several runs) never read a half-written copy: fsspec's simplecache writes in place and was seen to hand a
    concurrent loader worker an empty chunk.
    """
    from zarr.core.buffer import default_buffer_prototype
    from zarr.storage import WrapperStore

    class DiskCachedStore(WrapperStore):
        def _with_store(self, inner):
            return DiskCachedStore(inner)

        async def get(self, key, prototype=None, byte_range=None):
            prototype = prototype or default_buffer_prototype()
            if byte_range is not None:
                return await self._store.get(key, prototype, byte_range)
            f = cache_dir / hashlib.sha256(key.encode()).hexdigest()[:32]
            try:
                return prototype.buffer.from_bytes(f.read_bytes())
            except FileNotFoundError:
                pass
            value = await self._store.get(key, prototype)
            if value is not None:
                cache_dir.mkdir(parents=True, exist_ok=True)
                tmp = f.with_name(f"{f.name}.{os.getpid()}.{threading.get_ident()}.tmp")
                tmp.write_bytes(value.to_bytes())
                os.replace(tmp, f)
            return value

    return DiskCachedStore(store)


def fork_safe_store(make, path: str, read_only: bool):
    """zarr's FsspecStore whose file system is rebuilt in a forked child (a torch loader worker): fsspec's file
    systems refuse to be used across a fork ("This class is not fork-safe")."""
    from zarr.storage import FsspecStore

    class ForkSafeFsspecStore(FsspecStore):
        def __init__(self, fs=None, path="", read_only=False, **kw):
            self._make, self._pid = make, os.getpid()
            with warnings.catch_warnings():  # zarr's note that a sync fs is wrapped: intended for the cache
                warnings.simplefilter("ignore")
                super().__init__(fs=make() if fs is None else fs, path=path, read_only=read_only, **kw)

        @property
        def fs(self):
            if self._pid != os.getpid():
                self._fs, self._pid = self._make(), os.getpid()
            return self._fs

        @fs.setter
        def fs(self, value):
            self._fs = value

        def with_read_only(self, read_only: bool = False):
            return ForkSafeFsspecStore(path=self.path, read_only=read_only)

    return ForkSafeFsspecStore(path=path, read_only=read_only)


def record_of(data: bytes | None) -> list | None:
    """[size, sha256 (128 bits, hex)] of a chunk object's bytes (the manifest's record), None for no object."""
    return None if data is None else [len(data), hashlib.sha256(data).hexdigest()[:32]]
