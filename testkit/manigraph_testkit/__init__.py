"""manigraph's test and bench kit: stacks started for a test, network labs, fuzzers, floods.

Not shipped: no image installs it (``docker/``), and nothing in ``shared``, ``tools``,
``services`` or ``lab`` imports it; the tests, the benches and the soak do."""
