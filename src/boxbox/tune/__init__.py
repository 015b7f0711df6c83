"""`boxbox tune`: Optuna studies over a robot's declared parameters (docs/tuning.md).

space.py (the search space from the robot's declaration), objective.py (one trial: a few races),
storage.py (journal file or PostgreSQL, stale trials retried), study.py (workers, the run, the
summary), report.py (the HTML page), postgres.py (a PostgreSQL server for tests and bench-tune),
bench_tune.py (`boxbox bench-tune`).
"""
