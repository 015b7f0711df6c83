"""`boxbox tune --report DIR`: one self-contained HTML page for a study (DIR/report.html), in the
style of the race report: the optimisation history, the parameters' importances (Optuna's fANOVA
evaluator) and a slice plot per parameter (value against each complete trial's total time), drawn with
matplotlib and embedded as PNG, then the trials as a table.
"""

from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

from boxbox.report.figures import _figure, _img
from boxbox.report.race_report import CSS, _num, _table
from boxbox.tune.objective import PENALTY_S_PER_LAP, RESULT_ATTR, TuneConfig
from boxbox.tune.pick import PickRule


def _finished(study: Any) -> list:
    import optuna

    states = (optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.PRUNED)
    return [t for t in study.get_trials(deepcopy=False, states=states) if t.value is not None]


def _ylim(values: list[float], penalty_s: float) -> tuple[float, float] | None:
    """Axis limits leaving out penalised values (drawn at the top instead)."""
    good = [v for v in values if v < penalty_s]
    if not good:
        return None
    lo, hi = min(good), max(good)
    pad = max(0.5, 0.05 * (hi - lo))
    return lo - pad, hi + 3 * pad


def fig_history(study: Any, penalty_s: float):
    import optuna

    fig = _figure(9, 3.6)
    ax = fig.add_subplot()
    trials = _finished(study)
    done = [t for t in trials if t.state == optuna.trial.TrialState.COMPLETE]
    lim = _ylim([t.value for t in done], penalty_s)
    top = lim[1] - 0.04 * (lim[1] - lim[0]) if lim else 1.0  # the row of off-scale markers, inside the axes
    good = [(t.number, t.value) for t in done if t.value < penalty_s]
    if good:
        ax.scatter(*zip(*good, strict=True), marker="o", color="#1f77b4", s=18, label="complete")
    pruned = [t.number for t in trials if t.state == optuna.trial.TrialState.PRUNED]
    if pruned:  # their totals cover fewer tracks: not on the scale of the others
        ax.scatter(pruned, [top] * len(pruned), marker="x", color="#7f7f7f", s=24, label="pruned (at the top)")
    bad = [t.number for t in done if t.value >= penalty_s]
    if bad:
        ax.scatter(bad, [top] * len(bad), marker="^", color="#d62728", s=24, label="penalised (off the scale)")
    complete = sorted((t.number, t.value) for t in trials if t.state == optuna.trial.TrialState.COMPLETE)
    if complete:
        xs, best, run = [], [], math.inf
        for n, v in complete:
            run = min(run, v)
            xs.append(n)
            best.append(min(run, top))
        ax.step(xs, best, where="post", color="#2ca02c", label="best so far")
    if lim:
        ax.set_ylim(*lim)
    ax.set_xlabel("trial")
    ax.set_ylabel("total race time (s)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def fig_importances(study: Any):
    import optuna

    try:
        imp = optuna.importance.get_param_importances(study)
    except (RuntimeError, ValueError):  # too few complete trials, or one value everywhere
        return None
    if not imp:
        return None
    fig = _figure(7, 0.5 + 0.4 * len(imp))
    ax = fig.add_subplot()
    names = list(imp)[::-1]
    ax.barh(names, [imp[n] for n in names], color="#1f77b4")
    ax.set_xlabel("importance (fANOVA: share of the variance of the total time)")
    ax.set_xlim(0, 1)
    return fig


def fig_slice(study: Any, name: str, penalty_s: float):
    fig = _figure(4.2, 3.2)
    ax = fig.add_subplot()
    import optuna

    trials = [t for t in _finished(study) if name in t.params and t.state == optuna.trial.TrialState.COMPLETE]
    lim = _ylim([t.value for t in trials], penalty_s)
    top = lim[1] - 0.04 * (lim[1] - lim[0]) if lim else 1.0
    xs = [t.params[name] for t in trials]
    if xs and isinstance(xs[0], bool | str):
        cats = sorted({str(x) for x in xs})
        xs = [cats.index(str(x)) for x in xs]
        ax.set_xticks(range(len(cats)), cats)
    elif trials and getattr(trials[0].distributions.get(name), "log", False):
        ax.set_xscale("log")
    sc = ax.scatter(xs, [min(t.value, top) for t in trials], c=[t.number for t in trials], cmap="viridis", s=16)
    fig.colorbar(sc, ax=ax, label="trial")
    if lim:
        ax.set_ylim(*lim)
    ax.set_xlabel(name)
    ax.set_ylabel("total race time (s), complete trials")
    ax.grid(alpha=0.3)
    return fig


def build_report(study: Any, cfg: TuneConfig, pick: PickRule | None = None) -> str:
    from boxbox.report.tables import fmt_time
    from boxbox.tune.study_figures import progress, pruning_savings

    penalty = PENALTY_S_PER_LAP * cfg.laps
    p = progress(study)
    skipped, run, saved = pruning_savings(study, len(cfg.tracks))
    parts = [f"<h1>boxbox tune: {html.escape(cfg.study)}</h1>",
             f"<p class='meta'>robot {html.escape(cfg.robot)}, {html.escape(cfg.car)}, {cfg.skill_level}; tracks "
             f"{html.escape(', '.join(cfg.tracks))}, {cfg.laps} lap(s) each; parameters "
             f"{html.escape(', '.join(cfg.params))}. {p.complete} complete, {p.pruned} pruned, {p.failed} failed "
             f"trials; pruning skipped {skipped} of {skipped + run} races (about {saved:.0f} s). A race that faults, "
             f"does not finish or ends with damage over {cfg.damage_limit:g} counts {penalty:g} s.</p>"]
    pick = pick or PickRule()
    chosen = pick.choose(study, cfg)
    if chosen.trial is not None:
        best = chosen.trial
        rows = [[html.escape(k), html.escape(str(v))] for k, v in best.params.items()]
        parts += [f"<h2>Best trial ({pick.how}): #{best.number}, {fmt_time(best.value)}</h2>",
                  f"<p class='meta'>{html.escape(chosen.why)}</p>", _table(["parameter", "value"], rows)]
    parts += ["<h2>Optimisation history</h2>", _img(fig_history(study, penalty), "total time of each trial")]
    imp = fig_importances(study)
    parts.append("<h2>Parameter importances</h2>")
    parts.append(_img(imp, "importance of each parameter") if imp is not None else
                 "<p class='note'>needs at least two complete trials with different values</p>")
    parts.append("<h2>Slices</h2>")
    parts += [_img(fig_slice(study, name, penalty), f"total time against {name}") for name in cfg.params]
    parts += ["<h2>Trials</h2>", _trials_table(study, cfg)]
    title = html.escape(f"boxbox tune: {cfg.study}")
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{title}</title>"
            f"<meta name='viewport' content='width=device-width, initial-scale=1'><style>{CSS}</style></head>"
            f"<body>{''.join(parts)}</body></html>\n")


def _trials_table(study: Any, cfg: TuneConfig) -> str:
    rows = []
    for t in study.get_trials(deepcopy=False):
        result = t.user_attrs.get(RESULT_ATTR, {})
        notes = "; ".join(f"{r['track']}: {r['problem']}" for r in result.get("races", []) if r.get("problem"))
        rows.append([str(t.number), t.state.name.lower(), _num(t.value, "{:.3f}"),
                     html.escape(", ".join(f"{k}={_short(v)}" for k, v in t.params.items())),
                     _num(result.get("wall_s"), "{:.1f}"), html.escape(notes)])
    return _table(["#", "state", "total s", "parameters", "wall s", "penalties"], rows, "num")


def _short(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def write_report(study: Any, cfg: TuneConfig, out: Path, pick: PickRule | None = None) -> Path:
    from boxbox.files import write_text_atomic

    out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, build_report(study, cfg, pick))
    return out
