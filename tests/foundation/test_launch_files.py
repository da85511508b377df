"""Every launch file is well-formed XML (roslaunch refuses the whole launch otherwise, e.g. for ``--``
inside a comment), and every ``<env>`` sits where roslaunch takes it."""

from __future__ import annotations

from pathlib import Path
from xml.dom import minidom
from xml.parsers.expat import ExpatError

import pytest

REPO = Path(__file__).resolve().parents[2]
LAUNCH_FILES = sorted({*REPO.glob("launch/*.launch"), *REPO.glob("src/*/launch/*.launch"),
                       *REPO.glob("src/*/test/**/*.test"), *REPO.glob("tests/**/*.launch")})
ENV_PARENTS = {"launch", "include", "node", "machine", "test"}   # roslaunch's XML reference


@pytest.mark.parametrize("path", LAUNCH_FILES, ids=lambda p: str(p.relative_to(REPO)))
def test_the_launch_file_is_well_formed(path: Path) -> None:
    try:
        doc = minidom.parse(str(path))
    except ExpatError as err:
        pytest.fail(f"{path.relative_to(REPO)}: not well-formed XML: {err}")
    for env in doc.getElementsByTagName("env"):
        parent = env.parentNode.tagName
        assert parent in ENV_PARENTS, f"{path.relative_to(REPO)}: <env> inside <{parent}>"


def test_the_check_sees_a_broken_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.launch"
    bad.write_text("<launch>\n  <!-- chaos --machines -->\n</launch>\n")
    with pytest.raises(ExpatError):
        minidom.parse(str(bad))


@pytest.mark.parametrize("path", sorted(REPO.glob("launch/*.launch")), ids=lambda p: p.name)
def test_every_node_runs_numpy_with_one_blas_thread(path: Path) -> None:
    """Each robot launch file sets one OpenBLAS thread for all its nodes (at launch scope, so includes and a file
    started on its own alike): more threads spin on after each LAPACK call and took a core from the building."""
    doc = minidom.parse(str(path)).documentElement
    envs = {e.getAttribute("name"): e.getAttribute("value") for e in doc.childNodes
            if e.nodeType == e.ELEMENT_NODE and e.tagName == "env"}
    assert envs.get("OPENBLAS_NUM_THREADS") == "1", f"{path.name}: no <env name=\"OPENBLAS_NUM_THREADS\" value=\"1\"/>"
    assert envs.get("OMP_NUM_THREADS") == "1", f"{path.name}: no <env name=\"OMP_NUM_THREADS\" value=\"1\"/>"
