"""The solo bench's result (bench/solo.py): its rows, as JSON, CSV and the console's tables, with
each row's gap to the best of its track and car."""

from __future__ import annotations

import csv
import io
import statistics
from dataclasses import dataclass
from pathlib import Path

from rich.markup import escape
from rich.table import Table

from boxbox.files import write_json_atomic, write_text_atomic
from boxbox.model.skill import DEFAULT_SKILL_LEVEL
from boxbox.options import LearningMode
from boxbox.report.tables import fmt_time

ROW_FIELDS = ["track", "car", "robot", "name", "laps", "time", "best_lap", "damage", "pit_stops", "penalty",
              "wall_s", "error", "cached", "gap_to_best_s", "category", "car_driven", "rank", "run_dir",
              "stuck_s", "longest_stuck_s", "off_track_s", "fastest_lap", "limit_lap", "limit_gap_pct"]


@dataclass
class BenchResult:
    laps: int
    tracks: list[str]
    cars: list[str]
    robots: list[str]
    rows: list[dict]
    together: bool = False
    learning: LearningMode = "fresh"
    settings: dict | None = None
    skill_level: str = DEFAULT_SKILL_LEVEL.torcs_name
    wall_s: float = 0.0
    raced: int = 0
    cached: int = 0

    def to_json(self) -> dict:
        return {"laps": self.laps, "tracks": self.tracks, "cars": self.cars, "robots": self.robots,
                "together": self.together, "learning": self.learning, "settings": self.settings or {},
                "skill_level": self.skill_level,
                "wall_s": round(self.wall_s, 3), "raced": self.raced, "cached": self.cached, "rows": self.rows}

    def write_json(self, path: Path | str) -> None:
        write_json_atomic(path, self.to_json(), indent=1)

    def write_csv(self, path: Path | str) -> None:
        text = io.StringIO(newline="")
        writer = csv.DictWriter(text, fieldnames=ROW_FIELDS, extrasaction="ignore")
        writer.writeheader()
        for row in self.rows:
            writer.writerow({k: ("" if row.get(k) is None else row.get(k)) for k in ROW_FIELDS})
        write_text_atomic(path, text.getvalue())

    def table(self) -> Table:
        """One section per track (and car): each robot's time, best lap, damage, gap to the best."""
        mode = "together" if self.together else "each alone"
        title = (f"bench: {self.laps} lap{'s' if self.laps != 1 else ''}, {mode}, learning {self.learning}, "
                 f"skill level {self.skill_level}")
        if len(self.cars) == 1:
            title += f", {self.cars[0]}"
        if self.settings:
            title += ", set " + " ".join(f"{k}={v}" for k, v in self.settings.items())
        cols = ["track"] + (["car"] if len(self.cars) > 1 else []) + ["robot"] + (["pos"] if self.together else [])
        cols += ["laps", "time", "gap", "best lap", "damage", "pits", "penalty"]
        if any(r.get("limit_lap") for r in self.rows):
            cols += ["limit", "vs limit"]
        cols += ["wall s", "note"]
        table = Table(title=title)
        for col in cols:
            # only robot and note give way (wrap) when the terminal is narrow
            table.add_column(col, justify="left" if col in ("track", "car", "robot", "note") else "right",
                             no_wrap=col not in ("robot", "note"), max_width=48 if col == "note" else None)
        groups = _groups(self.rows)
        for n, ((track, car), rows) in enumerate(groups.items()):
            for i, r in enumerate(rows):
                best = r["gap_to_best_s"] == 0.0
                style = "bold green" if best else ""
                gap = "-" if r["gap_to_best_s"] is None else ("best" if best else f"+{r['gap_to_best_s']:.3f}")
                notes = []
                if r["cached"]:
                    notes.append("[dim]cached[/]")
                if r["car_driven"] and r["car_driven"] != car:
                    notes.append(f"drives {r['car_driven']}")
                if r["error"]:
                    notes.append(f"[red]{escape(_short(r['error'].splitlines()[0], 46))}[/]")
                elif r["laps"] < self.laps:
                    notes.append(f"[yellow]{r['laps']}/{self.laps} laps[/]")
                cells = {"track": track if i == 0 else "", "car": car if i == 0 else "",
                         "robot": _styled(escape(_robot_label(r["robot"])), style), "pos": str(r["rank"] or "-"),
                         "laps": str(r["laps"]), "time": _styled(fmt_time(r["time"]), style),
                         "gap": _styled(gap, style), "best lap": fmt_time(r["best_lap"]), "damage": str(r["damage"]),
                         "pits": str(r["pit_stops"]), "wall s": f"{r['wall_s']:.2f}" if r["wall_s"] else "-",
                         "note": " ".join(notes), "penalty": f"{r['penalty']:.1f}" if r["penalty"] else "-",
                         "limit": fmt_time(r.get("limit_lap")) if i == 0 else "", "vs limit": _vs_limit(r)}
                table.add_row(*(cells[c] for c in cols), end_section=i == len(rows) - 1 and n < len(groups) - 1)
        return table

    def summary_table(self) -> Table:
        """Per robot (and car) over all tracks: finished races, wins, mean gap to the best."""
        table = Table(title="per robot, all tracks")
        limited = any(r.get("limit_gap_pct") is not None for r in self.rows)
        for col in ("robot", "car", "finished", "best on", "mean gap s", "mean gap %", "total damage") + (
                ("mean vs limit %", "least vs limit %") if limited else ()):
            table.add_column(col, justify="left" if col in ("robot", "car") else "right")
        keys = list(dict.fromkeys((r["robot"], r["car"]) for r in self.rows))
        for robot, car in keys:
            rows = [r for r in self.rows if (r["robot"], r["car"]) == (robot, car)]
            done = [r for r in rows if r["gap_to_best_s"] is not None]
            gaps = [r["gap_to_best_s"] for r in done]
            pct = [100.0 * r["gap_to_best_s"] / (r["time"] - r["gap_to_best_s"]) for r in done]
            cells = [escape(_robot_label(robot)), car, f"{len(done)}/{len(rows)}",
                     str(sum(g == 0.0 for g in gaps)), f"{statistics.mean(gaps):.3f}" if gaps else "-",
                     f"{statistics.mean(pct):.2f}" if pct else "-", str(sum(r["damage"] for r in rows))]
            if limited:
                vs = [r["limit_gap_pct"] for r in rows if r.get("limit_gap_pct") is not None]
                cells += [f"{statistics.mean(vs):.2f}" if vs else "-", f"{min(vs):.2f}" if vs else "-"]
            table.add_row(*cells)
        return table


def _vs_limit(row: dict) -> str:
    """The fastest lap's gap to the limit lap, red when it beats the limit."""
    gap = row.get("limit_gap_pct")
    if gap is None:
        return "-"
    return f"[bold red]{gap:+.1f} %[/]" if gap < 0 else f"+{gap:.1f} %"


def _robot_label(entry: str) -> str:
    """'some/dir/robot.py:Class' -> 'robot.py:Class'; other entries as they are."""
    where, sep, cls = entry.rpartition(":")
    return f"{Path(where).name}:{cls}" if sep and (where.endswith(".py") or "/" in where) else entry


def _short(text: str, n: int) -> str:
    return text if len(text) <= n else text[:n - 1] + "…"


def _styled(text: str, style: str) -> str:
    return f"[{style}]{text}[/]" if style else text


def _groups(rows: list[dict]) -> dict[tuple[str, str], list[dict]]:
    out: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        out.setdefault((r["track"], r["car"]), []).append(r)
    return out


def set_gaps(rows: list[dict], laps: int) -> None:
    for group in _groups(rows).values():
        done = [r for r in group if not r["error"] and r["laps"] >= laps and r["time"] > 0]
        best = min((r["time"] for r in done), default=None)
        for r in group:
            r["gap_to_best_s"] = round(r["time"] - best, 3) if r in done else None
