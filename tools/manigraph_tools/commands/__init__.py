"""The subcommands ``manigraph_tools`` registers (``manigraph.commands`` entry points): one
module per command, ``commands/<verb>.py`` holding its ``command``, with its flags and the run
function that calls the library module doing the work.

Each is imported when it is asked for, not with the package: ``manigraph status`` should not
wait for the recorder's, the replayer's and ``up``'s imports (a third of a second, more on a
busy machine) before it can answer."""
