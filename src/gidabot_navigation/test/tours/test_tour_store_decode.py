"""The node's message decoding: malformed bytes and invalid UTF-8 are refused, not silently replaced."""

from __future__ import annotations

import io

import pytest

from gidabot_msgs.msg import Tour, TourIndex
from gidabot_navigation.ros.convert import tour_from_msg, tour_to_msg
from gidabot_navigation.tours.tour_store_node import decode


def raw(msg) -> bytes:
    buf = io.BytesIO()
    msg.serialize(buf)
    return buf.getvalue()


def sample() -> Tour:
    return to_ros_plain(file_name="visit.tour", tour_goals_info=["0, 014, Técnicos"], version=7, floor=0.0)


def to_ros_plain(**fields) -> Tour:
    msg = Tour()
    for k, v in fields.items():
        setattr(msg, k, v)
    return msg


def test_round_trip() -> None:
    data = raw(sample())
    msg = decode(Tour, data)
    core = tour_from_msg(msg)
    assert core.file_name == "visit.tour" and core.tour_goals_info == ("0, 014, Técnicos",) and core.version == 7


def test_invalid_utf8_is_refused() -> None:
    data = raw(sample()).replace("é".encode(), b"\xff\xfe")
    with pytest.raises(ValueError, match="not valid UTF-8"):
        decode(Tour, data)


def test_truncated_and_trailing_bytes_are_refused() -> None:
    data = raw(sample())
    with pytest.raises(ValueError, match="gidabot_msgs/Tour message"):
        decode(Tour, data[:-5])
    with pytest.raises(ValueError, match="malformed gidabot_msgs/Tour"):
        decode(Tour, data[:3])
    with pytest.raises(ValueError, match="trailing bytes"):
        decode(Tour, data + b"junk")


def test_index_length_prefix_lies() -> None:
    idx = TourIndex(robot="Kbot", file_names=["a.tour"], versions=[1], editor_robots=["Kbot"], deleted=[False])
    data = bytearray(raw(idx))
    with pytest.raises(ValueError):
        decode(TourIndex, bytes(data[:20]) + b"\xff\xff\xff\x7f" + bytes(data[24:]))


def test_to_ros_needs_no_master() -> None:
    from gidabot_navigation.tours.tour_store import TourMessage

    msg = tour_to_msg(TourMessage(file_name="x.tour", tour_goals_info=("0, 014, Lab",), version=3, stamp=5.0))
    assert msg.tour_goals_info == ["0, 014, Lab"] and msg.version == 3 and msg.header.stamp.to_sec() == 5.0
