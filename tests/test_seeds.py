"""Named seed streams: distinct names never share a stream, and a name always means the same numbers."""
from __future__ import annotations

import pytest

from svcore.seeds import PURPOSES, STREAMS, derive_seed, stream_seed


def test_every_named_stream_is_its_own_stream():
    """Two names on one (purpose, number) would draw the same numbers for different things: refuse it."""
    assert len(set(STREAMS.values())) == len(STREAMS)
    assert all(purpose in PURPOSES for purpose, _ in STREAMS.values())


def test_a_stream_is_its_purpose_and_number():
    for name, (purpose, number) in STREAMS.items():
        assert stream_seed(7, name, 3) == derive_seed(7, purpose, number, 3)


def test_unknown_stream_is_refused():
    with pytest.raises(ValueError, match="unknown seed stream"):
        stream_seed(0, "train.nothing")
