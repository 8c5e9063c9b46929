"""A real S3 protocol server on 127.0.0.1 for the object-store tests: moto's ThreadedMotoServer (server mode:
moto's decorator mode has no async support, zarr-python #2706), one per session, every bucket dropped per test.

Import the fixtures into a test module: ``from s3_fixtures import s3, s3_server  # noqa: F401``.
"""
from __future__ import annotations

import os
import urllib.request
from dataclasses import dataclass

import pytest

BUCKET = "svgen-test"


@pytest.fixture(scope="session")
def s3_server():
    """(endpoint URL) of a moto S3 server in this process; AWS_* variables point at it for the session."""
    from moto.server import ThreadedMotoServer

    server = ThreadedMotoServer(ip_address="127.0.0.1", port=0, verbose=False)
    server.start()
    host, port = server.get_host_and_port()
    endpoint = f"http://{host}:{port}"
    env = {"AWS_ACCESS_KEY_ID": "testing", "AWS_SECRET_ACCESS_KEY": "testing", "AWS_DEFAULT_REGION": "us-east-1",
           "AWS_ENDPOINT_URL": endpoint}
    saved = {k: os.environ.get(k) for k in [*env, "AWS_ENDPOINT_URL_S3", "SVGEN_STORAGE_OPTIONS"]}
    os.environ.update(env)
    for k in ("AWS_ENDPOINT_URL_S3", "SVGEN_STORAGE_OPTIONS"):
        os.environ.pop(k, None)
    try:
        yield endpoint
    finally:
        server.stop()
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@dataclass
class S3:
    endpoint: str
    bucket: str

    def url(self, name: str) -> str:
        return f"s3://{self.bucket}/{name}"

    def fs(self):
        import s3fs

        return s3fs.S3FileSystem(endpoint_url=self.endpoint, skip_instance_cache=True)


@pytest.fixture
def s3(s3_server, tmp_path, monkeypatch):
    """A fresh server state (moto's reset: every bucket gone) with one empty bucket; chunk cache under tmp_path."""
    urllib.request.urlopen(urllib.request.Request(f"{s3_server}/moto-api/reset", method="POST"), timeout=10).read()
    monkeypatch.setenv("SVGEN_OBJECT_CACHE", str(tmp_path / "s3cache"))
    monkeypatch.delenv("SVGEN_STORAGE_OPTIONS", raising=False)
    h = S3(s3_server, BUCKET)
    h.fs().mkdir(BUCKET)
    return h
