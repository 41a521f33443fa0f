"""The ``fsmctl`` command line: argument parsing, exit codes, one-line errors (the top layer).

One module per subcommand (``SUBCOMMAND_MODULES`` in :mod:`fsmctl.cli.main`).  Library code never imports this
package or raises its types: ``.importlinter`` and ``tests/test_layers.py`` check it.
"""
