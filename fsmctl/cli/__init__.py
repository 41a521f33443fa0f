"""The ``fsmctl`` command line: argument parsing, exit codes, one-line errors (the top layer).

Library code never imports this package or raises its types (``tests/test_layers.py``).
"""
