"""The built-in control laws, each a derivation script written with the public API (:mod:`fsmctl.symbolic.law`).

``python -m derive`` generates each into ``generated/laws/<name>/``; a user's script has the same form and is
derived with ``fsmctl derive FILE.py``.
"""

BUILTIN_LAWS: tuple[str, ...] = ("fsm", "pd", "super_twisting", "adaptive_fsm", "fsm_wheels", "fsm_event")
"""Module names under ``derive/laws/``, in the order ``fsmctl laws`` lists them."""
