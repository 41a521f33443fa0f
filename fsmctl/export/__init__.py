"""Exports of results to the exchange formats of the field (issue 30).

:mod:`fsmctl.export.aem`: attitude histories as CCSDS Attitude Ephemeris Messages (AEM, CCSDS 504.0-B-2),
one message per agent, written with the ``ccsds-ndm-py`` library and read back by it.

A layer between :mod:`fsmctl.studies` and :mod:`fsmctl.simulation`: it reads results, never runs them.
"""

from fsmctl.export.aem import (
    AemError,
    AttitudeEphemeris,
    EmptyResultError,
    NotAnAemError,
    UnknownAgentError,
    aem_quaternions,
    mrp_from_aem_quaternions,
    read_aem,
    write_aem,
)

__all__ = [
    "AemError",
    "AttitudeEphemeris",
    "EmptyResultError",
    "NotAnAemError",
    "UnknownAgentError",
    "aem_quaternions",
    "mrp_from_aem_quaternions",
    "read_aem",
    "write_aem",
]
