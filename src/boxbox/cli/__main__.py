"""`python -m boxbox.cli`: the same as the `boxbox` command."""

from boxbox.cli import main

main()
