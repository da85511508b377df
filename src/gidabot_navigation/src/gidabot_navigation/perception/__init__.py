"""People around a robot, seen by its own laser: detection, tracking, the visitor it guides (docs/perception.md)."""
