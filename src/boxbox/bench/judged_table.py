"""A `boxbox bench --json` run judged as a table: one cell per car and track for the Python robot
under test, each cell passing or missing, the misses counted, the table's damage and the summed time
per car (docs/pace.md, "Every installed car"; docs/rules.md, "Pace at each level").

The rule (one copy, here): a cell misses when the robot did not finish its laps, or took
DAMAGE_MISS or more on a track whose category is not exempt (road and oval; dirt tracks such as
mixed-2 are exempt: their category is the installed track's, the bench rows' `category`), or is no
faster than the fastest Debian robot that finished in that car (where one drives it).

Pure functions on the JSON document: `boxbox bench` prints the table after racing, `boxbox
bench-table` from files already written; bench/judged_compare.py sets two of them side by side.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from rich.table import Table

DAMAGE_MISS = 100  # docs/pace.md: damage 100 or more on a road or oval track misses
DAMAGE_EXEMPT_CATEGORIES = ("dirt",)  # TORCS's track category where damage does not count
ROW_KEYS = ("track", "car", "robot", "laps", "time", "damage", "error", "category")


def is_torcs_entry(entry: str) -> bool:
    """A TORCS robot's bench entry is 'module:idx' ('bt:2'); a Python robot's is anything else
    ('boxbox', 'my_robot.py:MyRobot', 'package.module:Class')."""
    module, sep, idx = entry.rpartition(":")
    return bool(sep and idx.isdigit() and module and "/" not in module and not module.endswith(".py"))


def finished(row: dict, laps: int) -> bool:
    return not row["error"] and row["laps"] >= laps and row["time"] > 0


@dataclass(frozen=True)
class Cell:
    """The robot under test in one car on one track, with the fastest Debian robot in that car."""

    car: str
    track: str
    category: str
    laps: int
    time_s: float | None  # None: not finished
    damage: int
    error: str | None
    debian: str | None = None  # the fastest Debian robot that finished in this car, if any
    debian_time_s: float | None = None
    reasons: tuple[str, ...] = ()  # why it misses; empty: it passes

    @property
    def miss(self) -> bool:
        return bool(self.reasons)

    def text(self) -> str:
        """As docs/pace.md writes it: 'time (damage where any) / the fastest Debian robot', or 'N laps (damage)'."""
        laps = f"{self.laps} lap{'s' if self.laps != 1 else ''}"
        shown = f"{self.time_s:.3f}" if self.time_s is not None else laps
        if self.damage:
            shown += f" ({self.damage})"
        if self.debian_time_s is not None:
            shown += f" / {self.debian_time_s:.3f}"
        return shown


def miss_reasons(row: dict, laps: int, debian: tuple[str, float] | None) -> tuple[str, ...]:
    """Why the robot's row misses (empty: it passes); `debian` is the fastest Debian robot that
    finished in that car, (entry, time), or None."""
    if not finished(row, laps):
        why = (row["error"] or "").splitlines()[0][:60] if row["error"] else ""
        return (f"not finished ({row['laps']} of {laps} laps{', ' + why if why else ''})",)
    reasons = []
    if row["category"] not in DAMAGE_EXEMPT_CATEGORIES and row["damage"] >= DAMAGE_MISS:
        reasons.append(f"damage {row['damage']}")
    if debian is not None and row["time"] >= debian[1]:
        reasons.append(f"{row['time'] - debian[1]:.3f} s behind {debian[0]}")
    return tuple(reasons)


@dataclass
class JudgedTable:
    """One Python robot's cells of a bench run, in the run's car and track order."""

    robot: str
    laps: int
    skill_level: str
    tracks: list[str]
    cars: list[str]
    cells: dict[tuple[str, str], Cell] = field(default_factory=dict)  # (car, track)

    @property
    def misses(self) -> list[Cell]:
        return [c for c in self.cells.values() if c.miss]

    @property
    def damage(self) -> int:
        return sum(c.damage for c in self.cells.values())

    def car_cells(self, car: str) -> list[Cell]:
        return [self.cells[car, t] for t in self.tracks if (car, t) in self.cells]

    def summed_s(self, car: str) -> tuple[float, int]:
        """The car's race times summed over the tracks it finished, and how many those are."""
        done = [c.time_s for c in self.car_cells(car) if c.time_s is not None]
        return sum(done), len(done)

    def summary_line(self) -> str:
        line = (f"{self.robot}: {len(self.misses)} of {len(self.cells)} cells miss (not finished, damage "
                f"{DAMAGE_MISS} or more off dirt, or no faster than a Debian robot in that car); "
                f"the table's damage {self.damage:,}")
        if len(self.cars) == 1:
            total, n = self.summed_s(self.cars[0])
            line += f"; summed time {total:.3f} s over the {n} of {len(self.cells)} tracks finished"
        return line

    def grid(self) -> Table:
        """Cars down, tracks across (one car: tracks down), the misses in bold red."""
        by_track = len(self.cars) == 1
        title = (f"{self.robot}, {self.laps} lap{'s' if self.laps != 1 else ''}, {self.skill_level}: time s "
                 "(damage) / the fastest Debian robot in the car; misses in bold red")
        table = Table(title=title)
        heads = ["track", self.cars[0]] if by_track else ["car", *self.tracks]
        for i, head in enumerate(heads):
            table.add_column(head, justify="left" if i == 0 else "right")
        if by_track:
            for track in self.tracks:
                table.add_row(track, console_text(self.cells.get((self.cars[0], track))))
        else:
            for car in self.cars:
                table.add_row(car, *(console_text(self.cells.get((car, t))) for t in self.tracks))
        return table

    def per_car(self) -> Table:
        table = Table(title=f"{self.robot} per car, over the tracks")
        for col in ("car", "finished", "summed time s", "damage", "misses"):
            table.add_column(col, justify="left" if col == "car" else "right")
        for car in self.cars:
            cells = self.car_cells(car)
            total, n = self.summed_s(car)
            table.add_row(car, f"{n}/{len(cells)}", f"{total:.3f}", str(sum(c.damage for c in cells)),
                          str(sum(c.miss for c in cells)))
        return table

    def markdown(self) -> str:
        """The table as docs/pace.md has it: misses in bold."""
        by_track = len(self.cars) == 1
        heads = ["track", self.cars[0]] if by_track else ["car", *self.tracks]
        lines = ["| " + " | ".join(heads) + " |", "|" + "---|" * len(heads)]
        keys = [[(self.cars[0], t)] for t in self.tracks] if by_track else \
            [[(car, t) for t in self.tracks] for car in self.cars]
        for label, row in zip(self.tracks if by_track else self.cars, keys, strict=True):
            texts = [_marked(self.cells.get(k)) for k in row]
            lines.append("| " + " | ".join([label, *texts]) + " |")
        return "\n".join(lines)


def console_text(cell: Cell | None) -> str:
    if cell is None:
        return "-"
    return f"[bold red]{cell.text()}[/]" if cell.miss else cell.text()


def _marked(cell: Cell | None) -> str:
    if cell is None:
        return "-"
    return f"**{cell.text()}**" if cell.miss else cell.text()


def check_doc(doc: object) -> dict:
    """The document when it is a `boxbox bench --json` run with what the table reads (ValueError
    naming what is wrong otherwise: found before any race, not after them)."""
    if not isinstance(doc, dict) or not isinstance(doc.get("rows"), list) or not isinstance(doc.get("laps"), int) \
            or not all(isinstance(doc.get(k), list) for k in ("tracks", "cars", "robots")):
        raise ValueError("not a `boxbox bench --json` file (no laps, tracks, cars, robots and rows)")
    for row in doc["rows"]:
        if not isinstance(row, dict) or any(k not in row for k in ROW_KEYS):
            raise ValueError(f"not a `boxbox bench --json` file (rows without {', '.join(ROW_KEYS)})")
    if not python_robots(doc):
        raise ValueError("the run has no Python robot to judge (only TORCS robots)")
    return doc


def python_robots(doc: dict) -> list[str]:
    return [r for r in doc["robots"] if not is_torcs_entry(r)]


def judged_tables(doc: dict) -> list[JudgedTable]:
    """One table per Python robot of a checked bench document (check_doc)."""
    laps = doc["laps"]
    fastest: dict[tuple[str, str], tuple[str, float]] = {}  # (car, track) -> the fastest Debian robot
    for row in doc["rows"]:
        key = (row["car"], row["track"])
        if is_torcs_entry(row["robot"]) and finished(row, laps) \
                and (key not in fastest or row["time"] < fastest[key][1]):
            fastest[key] = (row["robot"], row["time"])
    tables = []
    for robot in python_robots(doc):
        table = JudgedTable(robot, laps, str(doc.get("skill_level", "")), list(doc["tracks"]), list(doc["cars"]))
        for row in doc["rows"]:
            if row["robot"] != robot:
                continue
            key = (row["car"], row["track"])
            debian = fastest.get(key)
            table.cells[key] = Cell(
                car=row["car"], track=row["track"], category=row["category"], laps=row["laps"],
                time_s=row["time"] if finished(row, laps) else None, damage=int(row["damage"]), error=row["error"],
                debian=debian[0] if debian else None, debian_time_s=debian[1] if debian else None,
                reasons=miss_reasons(row, laps, debian))
        tables.append(table)
    return tables
