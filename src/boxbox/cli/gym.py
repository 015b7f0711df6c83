"""`boxbox scr-server`, `boxbox bench-gym` and `boxbox dataset`: the Gymnasium env's commands (in boxbox.gym)."""

from __future__ import annotations

import click

from boxbox import validate
from boxbox.cli.common import err, out, ready
from boxbox.cli.types import (
    LAPS,
    ClusterAddress,
    CommaList,
    FiniteFloatRange,
    GridPosition,
    OutputDir,
    OutputFile,
    WholeNumber,
    need_ray,
)


@click.command("scr-server")
@click.option("--port", type=WholeNumber(0, 65535), default=3001, show_default=True,
              help="UDP port on 127.0.0.1 (SCR's first car uses 3001; 0 picks a free one).")
@click.option("--track", default="g-track-1", show_default=True, help="Track name, e.g. e-track-2.")
@click.option("--car", default="car1-trb1", show_default=True, help="The client's car.")
@click.option("--opponents", type=CommaList("MODULE:IDX,...", unique=False), default="",
              help="TORCS robots, e.g. bt:2,berniw:3.")
@click.option("--laps", type=LAPS, default=1, show_default=True, help="Race length in laps.")
@click.option("--races", type=WholeNumber(0, None), default=1, show_default=True,
              help="Races to serve, one client after another (0: until Ctrl-C).")
@click.option("--client-timeout-s", type=FiniteFloatRange(*validate.CLIENT_TIMEOUT_S),
              default=validate.CLIENT_TIMEOUT_S_DEFAULT, show_default=True,
              help="A client silent this long is dropped (the race stops) and another client's identification "
                   "takes over (SCR's snakeoil client gives up after about 7 s).")
def scr_server(port, track, car, opponents, laps, races, client_timeout_s) -> None:
    """Serve SCR clients (the championship's UDP text protocol) on stock TORCS.

    \b
    Example: boxbox scr-server --port 3001 --track g-track-1
    then start an SCR client (snakeoil-style) against 127.0.0.1:3001.
    """
    from boxbox.gym.scr import serve

    ready()
    served = serve(port=port, track=track, car=car, opponents=opponents, laps=laps, races=races or None,
                   client_timeout_s=client_timeout_s,
                   log=lambda text: err.print(f"[dim]scr-server:[/] {text}", highlight=False))
    err.print(f"[dim]{served} race(s) served[/]")


@click.command("bench-gym")
@click.option("--track", default="g-track-1", show_default=True, help="Track name.")
@click.option("--steps", type=WholeNumber(1_000, None), default=100_000, show_default=True,
              help="Env steps of the one-env measurement.")
@click.option("--episode-steps", type=WholeNumber(10, None), default=1_000, show_default=True,
              help="Steps per episode in the speed measurements.")
@click.option("--envs", type=WholeNumber(0, 64), default=8, show_default=True,
              help="Sub-envs of the AsyncVectorEnv (0: skip it).")
@click.option("--vector-steps", type=WholeNumber(10, None), default=5_000, show_default=True,
              help="Steps of each sub-env of the AsyncVectorEnv.")
@click.option("--episodes", type=WholeNumber(10, None), default=1_000, show_default=True,
              help="Short episodes for the reset time, memory, files and processes.")
@click.option("--policy-steps", type=WholeNumber(0, None), default=40_000, show_default=True,
              help="Env steps of the random policy with the env's limits, without a spare race and with one "
                   "(0: skip it).")
@click.option("--multi-steps", type=WholeNumber(0, None), default=20_000, show_default=True,
              help="Steps of the pixel and the 2- and 4-car measurements (0: skip them).")
@click.option("--json", "json_file", type=OutputFile(), help="Write the rows as JSON.")
@click.option("--cluster", type=ClusterAddress(), default=None,
              help="The vector measurement's --envs envs as Ray actors on the cluster at ADDRESS ('auto' or the "
                   "head's HOST:PORT), one CPU each, instead of an AsyncVectorEnv here (docs/cluster.md).")
def bench_gym(track, steps, episode_steps, envs, vector_steps, episodes, policy_steps, multi_steps,
              json_file, cluster) -> None:
    """The Gymnasium env's speed, reset time and resource use, with gym_torcs's figures beside.

    Example: boxbox bench-gym --episodes 200
    """
    import contextlib
    from dataclasses import asdict

    from rich.table import Table

    from boxbox.files import write_json_atomic
    from boxbox.gym.bench_gym import run_bench
    from boxbox.torcs.checks import check_race

    need_ray(cluster)
    ready()
    check_race(track, "car1-trb1", 1)
    log = lambda text: err.print(f"[dim]bench-gym:[/] {text}", highlight=False)  # noqa: E731
    with contextlib.ExitStack() as stack:
        if cluster:
            from boxbox.bench.cluster import connected
            from boxbox.gym.vector_cluster import check_cpus

            stack.enter_context(connected(cluster))
            check_cpus(envs)  # before TORCS starts here
        rows = run_bench(track, steps, episode_steps, envs, vector_steps, episodes, policy_steps, log=log,
                         on_cluster=bool(cluster))
    if multi_steps:  # pixels, several learning cars (gym/bench_multi.py)
        from boxbox.gym.bench_multi import run_multi_bench

        rows += run_multi_bench(track, multi_steps, episode_steps, log=log)
    table = Table(title=f"bench-gym: boxbox/TORCS-v0 on {track}, random actions")
    for col in ("measure", "boxbox/TORCS-v0", "target", "gym_torcs (published)"):
        table.add_column(col, justify="right" if col == "boxbox/TORCS-v0" else "left")
    for r in rows:
        table.add_row(r.measure, r.value, r.target, r.gym_torcs)
    out.print(table)
    if json_file:
        write_json_atomic(json_file, [asdict(r) for r in rows], indent=1)


@click.command("dataset")
@click.argument("dataset_id", metavar="DATASET_ID", default="boxbox/robot-v0")
@click.option("--robot", default="boxbox", show_default=True,
              help="The robot that drives, as --robot of boxbox race takes it (e.g. my_robot.py:MyRobot).")
@click.option("--tracks", type=CommaList("TRACK,..."), default="g-track-1", show_default=True,
              help="Tracks, gone round in turn episode by episode.")
@click.option("--cars", type=CommaList("CAR,..."), default="car1-trb1", show_default=True, help="Cars, in turn.")
@click.option("--grid", type=CommaList("SLOT,...", item=GridPosition()), default="1", show_default=True,
              help="Grid slots (1 .. 40 or last), in turn: with --opponents, where the car starts among them.")
@click.option("--opponents", type=CommaList("MODULE:IDX,...", unique=False), default="",
              help="TORCS robots in every episode, e.g. bt:2,berniw:3.")
@click.option("--episodes", type=WholeNumber(1, None), default=None,
              help="Episodes to record, each one race of --laps from a start drawn from its seed [default: 10, "
                   "or as many as --steps takes].")
@click.option("--steps", type=WholeNumber(1, None), default=None,
              help="Steps to record in all (the last episode cut there); with --episodes, the first reached.")
@click.option("--noise", type=FiniteFloatRange(*validate.ACTION_NOISE), default=0.0, show_default=True,
              help="Gaussian noise on the robot's action, in each column's half range (0.1: a tenth of full steering "
                   "lock), so the data holds recoveries.")
@click.option("--seed", type=WholeNumber(0, 2**32 - 1), default=0, show_default=True,
              help="Episode i is seeded seed+i (its start point); the noise's seed too.")
@click.option("--laps", type=LAPS, default=1, show_default=True, help="Race length in laps.")
@click.option("--action-repeat", type=WholeNumber(1, 1000), default=validate.DATASET_ACTION_REPEAT, show_default=True,
              help="Drive steps per env step (the env's is 5; the shipped robot laps with 2 or 3, docs/gym.md).")
@click.option("--dir", "root", type=OutputDir(), default=None,
              help="The Minari datasets folder (default: $MINARI_DATASETS_PATH, else ~/.minari/datasets).")
@click.option("--replace", is_flag=True, help="Replace a dataset of that id (never a link, a file or another folder).")
def dataset(dataset_id, robot, tracks, cars, grid, opponents, episodes, steps, noise, seed, laps, action_repeat,
            root, replace) -> None:
    """Record a robot driving through boxbox/TORCS-v0 as a Minari dataset (offline RL, imitation).

    \b
    Example: boxbox dataset boxbox/robot-v0 --tracks g-track-1,e-track-2 --steps 20000 --noise 0.1
    then minari.load_dataset("boxbox/robot-v0"); infos["teacher_action"] is the robot's own action.
    """
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from boxbox.gym.dataset import DEFAULT_EPISODES, Recording, datasets_root, record

    place = datasets_root(root)
    rec = Recording(dataset_id=dataset_id, robot=robot, tracks=tuple(tracks), cars=tuple(cars), grid=tuple(grid),
                    opponents=tuple(opponents), episodes=episodes or (None if steps else DEFAULT_EPISODES), steps=steps,
                    noise=noise, seed=seed, laps=laps, action_repeat=action_repeat)
    ready()
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("steps"),
                  TimeElapsedColumn(), console=err, transient=True) as bar:
        task = bar.add_task(f"dataset {dataset_id}", total=steps)
        folder, n_episodes, n_steps = record(rec, place, replace, lambda: bar.advance(task))
    out.print(f"{dataset_id}: {n_episodes} episode(s), {n_steps} steps of {robot} (noise {noise:g}) in {folder}")
