"""CasADi-generated code for fsmctl.

DO NOT EDIT: every file in this folder is written by ``python -m derive`` from
the symbolic model in ``derive/`` (and ``laws/<name>/`` from ``derive/laws/<name>.py``);
``manifest.json`` files list them with their sha256.  Installed as the package data ``fsmctl._generated``.
"""
