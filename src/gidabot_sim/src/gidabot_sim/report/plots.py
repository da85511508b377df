"""The paths the robots followed, one PNG per floor over its blueprint (paper Fig. 7; ROS-free).

Thick while guiding the visitor, thin dashed while driving alone (to a meeting point, back to the visitor), the
tour's goals numbered by step.
"""

from __future__ import annotations

import math
from pathlib import Path

from gidabot_sim.errors import ReportError
from gidabot_sim.report.bags import GoalInfo, PoseSample, RobotRecord
from gidabot_sim.report.tables import guiding_intervals


def plot_paths(folder: Path, run: dict, records: list[RobotRecord]) -> list[Path]:
    """One PNG per floor: the path each robot followed over the floor's blueprint (paper Fig. 7)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    from gidabot_navigation.building.model import load_building
    from gidabot_navigation.errors import GidaBotError

    building_file = Path(run.get("building", "building/building.yaml"))
    if not building_file.is_absolute():   # relative to the run folder (folders can be moved)
        building_file = folder / building_file
    try:
        building = load_building(building_file)
    except GidaBotError as err:
        raise ReportError(f"{building_file}: cannot load the run's building: {err}") from err
    goals: dict[str, GoalInfo] = {}
    for rec in records:
        goals.update(rec.goals)
    written = []
    colours = ["#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf"]
    for floor in building.floors:
        img = Image.open(floor.blueprint_file)
        fig, ax = plt.subplots(figsize=(img.width / 100, img.height / 100 + 0.8), dpi=100)
        ax.imshow(img)
        ax.set_xlim(-0.5, img.width - 0.5)
        ax.set_ylim(img.height - 0.5, -0.5)
        for i, rec in enumerate(records):
            track = rec.track
            if rec.floor != floor.id or not track:
                continue
            colour = colours[i % len(colours)]
            intervals = guiding_intervals(rec.events, rec.goal_starts)
            for guiding, part in _split(track, intervals):
                uv = [floor.transform.to_pixel(p.x, p.y) for p in part]
                ax.plot([u for u, _ in uv], [v for _, v in uv], "-" if guiding else "--", color=colour,
                        linewidth=2.5 if guiding else 1.0, alpha=1.0 if guiding else 0.7)
            start, end = floor.transform.to_pixel(track[0].x, track[0].y), \
                floor.transform.to_pixel(track[-1].x, track[-1].y)
            ax.plot(*start, "o", color=colour, markersize=8)
            ax.plot(*end, "s", color=colour, markersize=8)
            ax.plot([], [], "-", color=colour, linewidth=2.5,
                    label=f"{rec.name}: guiding (thick), alone (dashed); o start, \u25a0 end")
        marks: dict[tuple[float, float], list[str]] = {}   # label 1 m from the goal towards its door
        for g in goals.values():
            if g.floor == floor.id:
                label = str(g.tour_step + 1) if g.tour_step >= 0 else g.goal_id
                key = (round(g.x + math.cos(g.yaw), 1), round(g.y + math.sin(g.yaw), 1))
                if label not in marks.setdefault(key, []):
                    marks[key].append(label)
        for (x, y), labels in marks.items():
            u, v = floor.transform.to_pixel(x, y)
            ax.annotate(",".join(sorted(labels, key=lambda t: (len(t), t))), (u, v), ha="center", va="center",
                        fontsize=9, fontweight="bold", color="white",
                        bbox={"boxstyle": "round,pad=0.25", "fc": "#333333", "ec": "none"})
        tour = run.get("tour", "")
        ax.set_title(f"{floor.names['en']} (floor {floor.label}): paths followed"
                     + (f" during {tour}; numbers: tour steps" if tour else ""), fontsize=12)
        ax.set_axis_off()
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.0), frameon=False, fontsize=10)
        out = folder / f"paths_floor{floor.label}.png"
        fig.savefig(out, bbox_inches="tight")
        plt.close(fig)
        written.append(out)
    return written


def _split(track: list[PoseSample], intervals: list[tuple[float, float]]) -> list[tuple[bool, list[PoseSample]]]:
    """The track cut into consecutive parts inside / outside the guiding intervals (parts share ends)."""
    def inside(t: float) -> bool:
        return any(s <= t <= e for s, e in intervals)

    parts: list[tuple[bool, list[PoseSample]]] = []
    for sample in track:
        state = inside(sample.t)
        if parts and parts[-1][0] == state:
            parts[-1][1].append(sample)
        else:
            prev = parts[-1][1][-1:] if parts else []
            parts.append((state, prev + [sample]))
    return parts
