"""Where the files GidaBot ships are, found through the package (ROS-free: rospkg, no rospy).

``gidabot_navigation``'s package directory holds the robot's resources: ``config/`` (the relay's
shared topics) and the repository's top-level ``launch/``, ``maps/`` and ``tours/``. In a source
checkout (devel space) the package directory is ``src/gidabot_navigation`` and those three are
symbolic links to the top level; in an install space (``catkin_make install``) they are copied
into ``share/gidabot_navigation``. Either way the package is found on ``ROS_PACKAGE_PATH``, which
the workspace's ``setup.bash`` sets (docs/architecture.md).
"""

from __future__ import annotations

from pathlib import Path

import rospkg

from gidabot_navigation.errors import ResourceError

PACKAGE = "gidabot_navigation"


def package_dir(package: str = PACKAGE) -> Path:
    """The directory of ``package`` (``src/<package>`` in a checkout, ``share/<package>`` when installed)."""
    try:
        return Path(rospkg.RosPack().get_path(package))
    except rospkg.ResourceNotFound as err:
        raise ResourceError(f"package {package} not found on ROS_PACKAGE_PATH: source the workspace's "
                            f"setup.bash (devel or install space) first") from err


def resource(*parts: str, package: str = PACKAGE) -> Path:
    """The file or directory ``parts`` of ``package``, symbolic links resolved, e.g.
    ``resource("launch", "robot.launch")``, ``resource("maps", "faculty")``, ``resource("tours")``."""
    pkg = package_dir(package)
    path = pkg.joinpath(*parts).resolve()
    if not path.exists():
        raise ResourceError(f"{'/'.join(parts)} not found in package {package} ({pkg})")
    return path
