"""The lab's subcommands (``manigraph.commands`` entry points), one module per command,
``commands/<verb>.py`` holding its ``command``: demonstrate (``demos``), evaluate (``eval``,
``suite``, ``select``), improve (``improve``), explain and the paper's experiments. Training
still lives with the planner (``manigraph train``). Long work shows a progress bar on stderr
when stderr is a terminal; piped or redirected, only results are printed."""
