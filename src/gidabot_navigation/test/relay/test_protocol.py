"""Relay wire format: framing, size limits, HMAC, message bodies (no sockets)."""

from __future__ import annotations

import random
import socket

import pytest

from gidabot_navigation.errors import FrameRejected
from gidabot_navigation.interface import Node, Topic, global_name
from gidabot_navigation.relay.protocol import (
    HEADER,
    MAC_LEN,
    FrameReader,
    FrameType,
    Hello,
    Message,
    check_mac,
    decode_message,
    encode_frame,
    encode_message,
    hello_key,
    session_keys,
)

KEY = hello_key(b"0123456789abcdef0123")


def frames_of(data: bytes, max_body: int = 1 << 20, chunk: int | None = None) -> list:
    r = FrameReader(max_body)
    out = []
    step = chunk or len(data) or 1
    for i in range(0, len(data), step):
        r.feed(data[i:i + step])
        while (f := r.next()) is not None:
            out.append(f)
    return out


@pytest.mark.parametrize("chunk", [1, 3, 7, 64, None])
def test_stream_split_anywhere_gives_the_same_frames(chunk: int | None) -> None:
    bodies = [b"", b"x", bytes(range(256)) * 5, b"last"]
    data = b"".join(encode_frame(FrameType.EVENT, b, KEY, i) for i, b in enumerate(bodies))
    got = frames_of(data, chunk=chunk)
    assert [f.body for f in got] == bodies
    for i, f in enumerate(got):
        check_mac(f, KEY, i)


def test_socketpair_carries_frames() -> None:
    a, b = socket.socketpair()
    with a, b:
        payload = bytes(random.Random(1).randbytes(100_000))
        a.sendall(encode_frame(FrameType.STATE, payload, KEY, 5))
        r = FrameReader(1 << 20)
        frame = None
        while frame is None:
            r.feed(b.recv(4096))
            frame = r.next()
        assert frame.body == payload
        check_mac(frame, KEY, 5)


def test_oversize_is_refused_from_the_header_alone() -> None:
    r = FrameReader(max_body=1000)
    r.feed(HEADER.pack(b"GR", 1, int(FrameType.EVENT), 0, 10_000_000))
    with pytest.raises(FrameRejected) as err:
        r.next()
    assert err.value.reason == "oversize"
    assert r.buffered == HEADER.size            # nothing of the body was waited for


@pytest.mark.parametrize("header", [
    HEADER.pack(b"XX", 1, 16, 0, 0),            # bad magic
    HEADER.pack(b"GR", 9, 16, 0, 0),            # unknown version
    HEADER.pack(b"GR", 1, 99, 0, 0),            # unknown type
    HEADER.pack(b"GR", 1, 16, 0x80, 0),         # unknown flag
])
def test_bad_headers_are_malformed(header: bytes) -> None:
    r = FrameReader(1000)
    r.feed(header)
    with pytest.raises(FrameRejected) as err:
        r.next()
    assert err.value.reason == "malformed"


def test_mac_checks() -> None:
    good = frames_of(encode_frame(FrameType.EVENT, b"body", KEY, 3))[0]
    check_mac(good, KEY, 3)
    with pytest.raises(FrameRejected, match="wrong MAC"):
        check_mac(good, KEY, 4)                                     # replayed / reordered
    with pytest.raises(FrameRejected, match="wrong MAC"):
        check_mac(good, hello_key(b"another secret, 16+ bytes"), 3)
    plain = frames_of(encode_frame(FrameType.EVENT, b"body"))[0]
    with pytest.raises(FrameRejected, match="without a MAC") as err:
        check_mac(plain, KEY, 0)
    assert err.value.reason == "auth"
    with pytest.raises(FrameRejected, match="no secret"):
        check_mac(good, None, 0)
    tampered = bytearray(encode_frame(FrameType.EVENT, b"body", KEY, 3))
    tampered[HEADER.size] ^= 1
    with pytest.raises(FrameRejected, match="wrong MAC"):
        check_mac(frames_of(bytes(tampered))[0], KEY, 3)
    assert len(encode_frame(FrameType.EVENT, b"", KEY)) == HEADER.size + MAC_LEN


def test_session_keys_differ_per_direction_nonce_and_link() -> None:
    na, nb = b"a" * 16, b"b" * 16
    k_ab, k_ba = session_keys(b"s" * 16, "A_B", na, nb)
    assert k_ab != k_ba
    assert session_keys(b"s" * 16, "A_C", na, nb)[0] != k_ab
    assert session_keys(b"s" * 16, "A_B", na, b"c" * 16)[0] != k_ab


def test_message_and_hello_round_trip() -> None:
    m = Message(Topic.GOALS, global_name(Node.GOAL_MANAGER), "f" * 32, b"\x00\x01payload", 42)
    assert decode_message(encode_message(m, True), True) == m
    s = Message(Topic.STATUS, global_name(Node.MULTIROBOT_NAVIGATION), "e" * 32, b"x")
    assert decode_message(encode_message(s, False), False) == s
    h = Hello("A_B", "b", b"n" * 16, b"e" * 16, 7, 8, 9)
    assert Hello.decode(h.encode()) == h


@pytest.mark.parametrize("cut", range(0, 40, 3))
def test_truncated_bodies_are_malformed_never_crash(cut: int) -> None:
    body = encode_message(Message("/t", "/c", "m" * 32, b"p" * 10, 1), True)
    if cut >= len(body):
        return
    with pytest.raises(FrameRejected) as err:
        decode_message(body[:cut], True)
    assert err.value.reason == "malformed"


def test_random_garbage_never_crashes_the_decoders() -> None:
    rng = random.Random(7)
    for _ in range(500):
        blob = rng.randbytes(rng.randint(0, 80))
        for decode in (lambda b: decode_message(b, True), lambda b: decode_message(b, False), Hello.decode):
            try:
                decode(blob)
            except FrameRejected as err:
                assert err.reason == "malformed"
        r = FrameReader(1000)
        r.feed(blob)
        try:
            while r.next() is not None:
                pass
        except FrameRejected as err:
            assert err.reason in ("malformed", "oversize")


def test_non_utf8_strings_are_malformed() -> None:
    body = bytearray(encode_message(Message("/t", "/c", "m", b"", 1), True))
    body[8 + 2] = 0xFF                           # first byte of the topic string
    with pytest.raises(FrameRejected, match="not UTF-8"):
        decode_message(bytes(body), True)
