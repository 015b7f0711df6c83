"""`boxbox bench --against BASE.json` (and `boxbox bench-table RUN.json --against BASE.json`): a
run's judged table (bench/judged_table.py) set against an earlier run's, cell by cell and in sum.

A driving change moves many cells a little both ways (a solo race is deterministic but chaotic), so
it is judged on the whole table: the misses before and after, the cells that turned into misses
and those that stopped missing, the table's damage, and per car the race times summed over the
tracks both runs finished, with their ratio (for the level table, one car over every track, that
ratio is the measure), then the cells whose time moved most.
"""

from __future__ import annotations

from dataclasses import dataclass

from rich.table import Table

from boxbox.bench.judged_table import Cell, JudgedTable, console_text, judged_tables, python_robots

MOVED_SHOWN = 10  # cells listed under "moved most"
NAMES_SHOWN = 4  # tracks or cars named in a mismatch's one line


def shape(doc: dict) -> tuple[int, tuple[str, ...], tuple[str, ...]]:
    """Laps, tracks and cars of a checked bench document: two runs compare cell by cell only when these match."""
    return doc["laps"], tuple(sorted(doc["tracks"])), tuple(sorted(doc["cars"]))


def mismatch(base: dict, run: dict) -> str | None:
    """What keeps two checked bench documents from being compared, in one line, or None."""
    (laps_b, tracks_b, cars_b), (laps_r, tracks_r, cars_r) = shape(base), shape(run)
    if laps_b != laps_r:
        return f"it raced {laps_b} lap{'s' if laps_b != 1 else ''}, this run {laps_r}"
    if tracks_b != tracks_r:
        return f"it raced other tracks ({_differ(tracks_b, tracks_r)})"
    if cars_b != cars_r:
        return f"it raced other cars ({_differ(cars_b, cars_r)})"
    robots_b, robots_r = python_robots(base), python_robots(run)
    if robots_b != robots_r and not (len(robots_b) == 1 and len(robots_r) == 1):
        return f"its Python robots ({', '.join(robots_b)}) are not this run's ({', '.join(robots_r)})"
    return None


def _differ(base: tuple[str, ...], run: tuple[str, ...]) -> str:
    parts = []
    for where, names in (("there", sorted(set(base) - set(run))), ("here", sorted(set(run) - set(base)))):
        if names:
            more = f" and {len(names) - NAMES_SHOWN} more" if len(names) > NAMES_SHOWN else ""
            parts.append(f"only {where}: {', '.join(names[:NAMES_SHOWN])}{more}")
    return "; ".join(parts)


@dataclass
class CarSums:
    car: str
    cells: int  # the tracks both runs finished in this car
    base_s: float
    run_s: float
    base_damage: int
    run_damage: int
    base_misses: int
    run_misses: int

    @property
    def ratio(self) -> float | None:
        return self.run_s / self.base_s if self.base_s else None


@dataclass
class TableComparison:
    base: JudgedTable
    run: JudgedTable
    new_misses: list[tuple[Cell, Cell]]  # (base, run) cells that passed and now miss
    cleared: list[tuple[Cell, Cell]]  # cells that missed and now pass
    cars: list[CarSums]
    moved: list[tuple[Cell, Cell]]  # both finished, the largest time changes first

    @property
    def total(self) -> CarSums:
        """Every car's sums added: the whole table's."""
        return CarSums("all", *(sum(getattr(c, k) for c in self.cars) for k in (
            "cells", "base_s", "run_s", "base_damage", "run_damage", "base_misses", "run_misses")))

    def lines(self, base_name: str) -> list[str]:
        t = self.total
        out = [f"against {base_name} ({self.base.robot} there, {self.run.robot} here): misses "
               f"{t.base_misses} -> {t.run_misses}, table damage {t.base_damage:,} -> {t.run_damage:,}, "
               f"summed time over the cells both finished ({t.cells}) {t.base_s:.3f} -> {t.run_s:.3f} s"
               + (f" (ratio {t.ratio:.5f})" if t.ratio else "")]
        out.append(f"now missing ({len(self.new_misses)})" + (":" if self.new_misses else ""))
        out += [f"  {b.car} {b.track}: {b.text()} -> {r.text()} ({'; '.join(r.reasons)})" for b, r in self.new_misses]
        out.append(f"no longer missing ({len(self.cleared)})" + (":" if self.cleared else ""))
        out += [f"  {b.car} {b.track}: {b.text()} -> {r.text()} (was {'; '.join(b.reasons)})" for b, r in self.cleared]
        return out

    def per_car(self, base_name: str) -> Table:
        table = Table(title=f"per car against {base_name}: summed over the tracks both runs finished")
        for col in ("car", "tracks", "summed s there", "summed s here", "ratio", "damage", "misses"):
            table.add_column(col, justify="left" if col == "car" else "right")
        for c in [*self.cars, self.total]:
            ratio = c.ratio
            style = "" if ratio is None or ratio == 1.0 else ("green" if ratio < 1.0 else "red")
            ratio_text = "-" if ratio is None else f"{ratio:.5f}"
            table.add_row(c.car, str(c.cells), f"{c.base_s:.3f}", f"{c.run_s:.3f}",
                          f"[{style}]{ratio_text}[/]" if style else ratio_text,
                          f"{c.base_damage} -> {c.run_damage}", f"{c.base_misses} -> {c.run_misses}",
                          end_section=c.car == self.cars[-1].car)
        return table

    def moved_table(self, base_name: str) -> Table:
        table = Table(title=f"the cells that moved most against {base_name}")
        for col in ("car", "track", "there", "here", "change s", "change %"):
            table.add_column(col, justify="left" if col in ("car", "track") else "right")
        for b, r in self.moved:
            assert b.time_s is not None and r.time_s is not None
            d = r.time_s - b.time_s
            table.add_row(b.car, b.track, console_text(b), console_text(r), f"{d:+.3f}", f"{100.0 * d / b.time_s:+.2f}")
        return table


def compare_tables(base: JudgedTable, run: JudgedTable) -> TableComparison:
    """Two judged tables of the same cars and tracks, cell by cell and in sum per car."""
    pairs = [(base.cells[k], run.cells[k]) for k in run.cells if k in base.cells]
    cars = []
    for car in run.cars:
        mine = [(b, r) for b, r in pairs if b.car == car]
        both = [(b, r) for b, r in mine if b.time_s is not None and r.time_s is not None]
        cars.append(CarSums(car, len(both), sum(b.time_s or 0.0 for b, _ in both),
                            sum(r.time_s or 0.0 for _, r in both),
                            sum(b.damage for b, _ in mine), sum(r.damage for _, r in mine),
                            sum(b.miss for b, _ in mine), sum(r.miss for _, r in mine)))
    finished_both = [(b, r) for b, r in pairs if b.time_s is not None and r.time_s is not None]
    moved = sorted(finished_both, key=lambda p: -abs((p[1].time_s or 0.0) - (p[0].time_s or 0.0)))
    return TableComparison(base, run, [(b, r) for b, r in pairs if r.miss and not b.miss],
                           [(b, r) for b, r in pairs if b.miss and not r.miss], cars, moved[:MOVED_SHOWN])


def compare_docs(base_doc: dict, run_doc: dict) -> list[TableComparison]:
    """Each Python robot's table of run_doc against base_doc's (the same robot, or the one of each);
    ValueError when the two runs do not match (mismatch)."""
    why = mismatch(base_doc, run_doc)
    if why:
        raise ValueError(f"the two runs cannot be compared cell by cell: {why}")
    return [compare_tables(b, r) for b, r in zip(judged_tables(base_doc), judged_tables(run_doc), strict=True)]
