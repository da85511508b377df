"""Files by name only: what a directory offers is found once, regular files with plain names; serving opens the
listed file without following a link, and refuses what is not a regular file (any more) or is too large."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from gidabot_web.web.files import NamedFiles


@pytest.fixture
def www(tmp_path: Path) -> Path:
    d = tmp_path / "www"
    d.mkdir()
    (d / "page.html").write_text("<p>hi</p>")
    (d / "app.js").write_text("1;")
    (d / ".hidden").write_text("secret")
    (d / "sub").mkdir()
    (d / "sub" / "x.js").write_text("2;")
    (tmp_path / "outside.txt").write_text("outside")
    os.symlink(tmp_path / "outside.txt", d / "link.txt")
    os.symlink("/etc/passwd", d / "passwd")
    os.symlink(d / "app.js", d / "alias.js")
    os.mkfifo(d / "fifo")
    (d / "big.bin").write_bytes(b"x" * 2000)
    return d


def test_a_directory_offers_its_regular_files_with_plain_names(www: Path) -> None:
    files = NamedFiles.directory(www, max_bytes=1000)
    assert files.names() == ["app.js", "big.bin", "page.html"]
    assert files.read("page.html").body == b"<p>hi</p>"
    assert files.read("page.html").content_type == "text/html; charset=utf-8"
    assert files.read("app.js").content_type == "text/javascript; charset=utf-8"
    for name in ("link.txt", "passwd", "alias.js", "fifo", ".hidden", "sub", "sub/x.js", "../outside.txt",
                 "/etc/passwd", "big.bin", "", None, 3, "page.html\x00"):
        assert files.read(name) is None, name


def test_a_listed_file_replaced_by_a_link_or_a_directory_is_not_served(www: Path) -> None:
    files = NamedFiles.directory(www)
    (www / "page.html").unlink()
    os.symlink("/etc/passwd", www / "page.html")
    assert files.read("page.html") is None
    (www / "app.js").unlink()
    (www / "app.js").mkdir()
    assert files.read("app.js") is None


def test_listed_names_must_be_plain(tmp_path: Path) -> None:
    with pytest.raises(ValueError):
        NamedFiles({"../x": tmp_path / "x"})
    with pytest.raises(ValueError):
        NamedFiles({"a/b": tmp_path / "x"})
    assert NamedFiles({"floor-0.png": tmp_path / "missing.png"}).read("floor-0.png") is None
