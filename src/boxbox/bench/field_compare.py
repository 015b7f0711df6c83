"""`boxbox bench-field --against BASE.json`: this run's races set against an earlier run's, race by race.

A change to a robot's racecraft moves its field races by chance as much as by design: one contact
more or less on lap 1 reshuffles the rest of the race (docs/racecraft.md, "Chance": 0.1 % less
grip, worth 0.03 s a lap alone, moved one 10-lap race on each of the 38 tracks from 86 places summed
to 90).  So the comparison pairs each race with the same race of the base run (the same track, length and repeat),
sums the robot's figures over the pairs, and says how large a difference in places chance alone
makes: the spread of the place sums between repeats (one pass over the tracks each), as a standard
deviation of the difference of the two totals.  With one race a track there is no spread to take.

Both files are `bench-field --json` output: one run (`rows`) or several lengths and repeats (`runs`).
"""

from __future__ import annotations

import math
import statistics
from dataclasses import dataclass, field

from rich.table import Table

from boxbox.bench.field import ANCHOR, LOW_DAMAGE, race_targets

ROW_KEYS = ("track", "role", "rank", "damage", "field_damage", "error")


def passes_of(doc: dict) -> list[dict]:
    """The runs (one pass over the tracks each) of a bench-field JSON document, each checked for
    what the comparison reads (ValueError otherwise: found before any race, not after them)."""
    if isinstance(doc, dict) and isinstance(doc.get("runs"), list):
        passes = doc["runs"]
    elif isinstance(doc, dict) and isinstance(doc.get("rows"), list):
        passes = [doc]
    else:
        raise ValueError("not a `boxbox bench-field --json` file (no runs or rows)")
    for p in passes:
        rows = p.get("rows") if isinstance(p, dict) else None
        if not isinstance(rows, list) or not isinstance(p.get("tracks"), list) \
                or not all(isinstance(r, dict) and all(k in r for k in ROW_KEYS) for r in rows):
            raise ValueError(f"not a `boxbox bench-field --json` file (a run without tracks, or rows without "
                             f"{', '.join(ROW_KEYS)})")
    return passes


def shape_of(doc: dict) -> list[tuple[int, tuple[str, ...]]]:
    """Per pass, its race length and tracks: two runs compare race by race only when these match."""
    return _shape(passes_of(doc))


def _shape(passes: list[dict]) -> list[tuple[int, tuple[str, ...]]]:
    return [(int(p.get("laps", 0)), tuple(p["tracks"])) for p in passes]


@dataclass
class Totals:
    """The robot's figures summed over the paired races."""

    races: int = 0
    places: int = 0
    wins: int = 0
    damage: int = 0
    low_damage: int = 0
    ahead: int = 0
    field_damage_not_higher: int = 0
    every_target: int = 0  # all four in the same race
    pass_places: list[int] = field(default_factory=list)  # the place sum of each pass

    def add(self, row: dict, anchor: dict | None, start_slot: int) -> int:
        place = row["rank"] or start_slot  # not placed (out before a lap): last, as bench/field_grid.py
        targets = race_targets(row, anchor)
        self.races += 1
        self.places += place
        self.wins += targets.won
        self.damage += int(row["damage"])
        self.low_damage += targets.low_damage
        self.ahead += targets.ahead_of_anchor
        self.field_damage_not_higher += targets.field_damage_not_higher
        self.every_target += targets.all_met
        return place


def _rows(run: dict, role: str) -> dict[str, dict]:
    return {r["track"]: r for r in run["rows"] if r["role"] == role and not r["error"]}


@dataclass
class Comparison:
    base: Totals
    new: Totals
    places_by_track: dict[str, tuple[list[int], list[int]]]  # (base, new) places per paired race
    damage_by_track: dict[str, tuple[int, int]]

    @property
    def chance_places(self) -> float | None:
        """One standard deviation of the difference of the two place totals from chance alone:
        sqrt(n) x the pooled spread of a pass's place sum, over n passes (None: fewer than 2)."""
        a, b = self.base.pass_places, self.new.pass_places
        if len(a) < 2 or len(b) < 2:
            return None
        return math.sqrt(len(a) * statistics.variance(a) + len(b) * statistics.variance(b))

    def lines(self, base_name: str) -> list[str]:
        b, n = self.base, self.new
        d = n.places - b.places
        out = [f"against {base_name}, {n.races} races paired: places {b.places} -> {n.places} ({d:+d}), "
               f"wins {b.wins} -> {n.wins}, damage {b.damage} -> {n.damage} "
               f"({_percent(b.damage, n.damage)}), under {LOW_DAMAGE} {b.low_damage} -> {n.low_damage}, "
               f"ahead of {ANCHOR} {b.ahead} -> {n.ahead}, field damage no higher "
               f"{b.field_damage_not_higher} -> {n.field_damage_not_higher}, all four in one race "
               f"{b.every_target} -> {n.every_target}"]
        sd = self.chance_places
        if sd is None:
            out.append("chance: one race a track, no spread to judge by; race both with --repeats 3 or more")
        else:
            verdict = "within" if abs(d) <= 2.0 * sd else "beyond"
            out.append(f"chance: about {sd:.1f} places one way or the other (one standard deviation, from the "
                       f"spread between repeats); {d:+d} is {verdict} two of them")
        return out

    def table(self, base_name: str) -> Table:
        table = Table(title=f"bench-field against {base_name}: the robot's places per race, base -> this run")
        for col in ("track", "base", "this run", "places", "damage"):
            table.add_column(col, justify="left" if col in ("track", "base", "this run") else "right")
        for track, (pb, pn) in self.places_by_track.items():
            db, dn = self.damage_by_track[track]
            style = "" if sum(pn) == sum(pb) else ("green" if sum(pn) < sum(pb) else "red")
            table.add_row(track, " ".join(map(str, pb)), " ".join(map(str, pn)),
                          f"[{style}]{sum(pb)} -> {sum(pn)}[/]" if style else f"{sum(pb)} -> {sum(pn)}",
                          f"{db} -> {dn}")
        return table


def _percent(before: int, after: int) -> str:
    return f"{100.0 * (after - before) / before:+.1f} %" if before else "-"


def compare(base_doc: dict, new_doc: dict) -> Comparison:
    """The robot's races in new_doc against the same races in base_doc (ValueError when the two
    did not race the same lengths and tracks in the same passes)."""
    base_passes, new_passes = passes_of(base_doc), passes_of(new_doc)
    if _shape(base_passes) != _shape(new_passes):
        raise ValueError("the two runs differ in tracks, laps or repeats: race the same --tracks, --laps and "
                         "--repeats as the base run")
    base, new = Totals(), Totals()
    places: dict[str, tuple[list[int], list[int]]] = {}
    damage: dict[str, tuple[int, int]] = {}
    for run_b, run_n in zip(base_passes, new_passes, strict=True):
        slot = len(run_n.get("field", [])) + 1
        rb, rn = _rows(run_b, "robot"), _rows(run_n, "robot")
        ab, an = _rows(run_b, "anchor"), _rows(run_n, "anchor")
        sum_b = sum_n = 0
        for track in run_n["tracks"]:
            if track not in rb or track not in rn:
                continue  # failed in either: not paired
            pb, pn = places.setdefault(track, ([], []))
            pb.append(base.add(rb[track], ab.get(track), slot))
            pn.append(new.add(rn[track], an.get(track), slot))
            sum_b, sum_n = sum_b + pb[-1], sum_n + pn[-1]
            db, dn = damage.get(track, (0, 0))
            damage[track] = (db + int(rb[track]["damage"]), dn + int(rn[track]["damage"]))
        base.pass_places.append(sum_b)
        new.pass_places.append(sum_n)
    return Comparison(base, new, places, damage)
