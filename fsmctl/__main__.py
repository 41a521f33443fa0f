"""``python -m fsmctl``: the ``fsmctl`` command line."""

from fsmctl.cli.main import console_main

if __name__ == "__main__":
    console_main()
