"""The version of fsmctl, in a module of its own: library code reads it without importing the package's
top level (``fsmctl/__init__.py`` imports the scenario classes, so ``from fsmctl import __version__`` inside
:mod:`fsmctl.model` would close an import cycle).
"""

__version__ = "0.1.0"
