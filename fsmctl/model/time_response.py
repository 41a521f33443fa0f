"""Formation time responses for people: one colour per agent, signals grouped, shared by every figure.

Every figure fsmctl draws (the plug-in's responses, :class:`fsmctl.SimulationResult` plots, the reproduction's
Figs 1-9) colours agent ``i`` with :func:`agent_color` ``(i)``, so an agent keeps its colour across figures.
"""

from __future__ import annotations

__all__ = ["agent_color"]

# matplotlib's "tab10" qualitative palette, then "tab20"'s lighter shades: 20 agents before a colour repeats
_PALETTE = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
    "#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2", "#c7c7c7", "#dbdb8d", "#9edae5",
)  # fmt: skip


def agent_color(i: int) -> str:
    """The colour of agent ``i`` (0-based) in every fsmctl figure.

    Parameters
    ----------
    i : int
        Agent index, 0-based (the paper's spacecraft ``i + 1``).

    Returns
    -------
    str
        A hex colour: matplotlib's ``tab10`` palette for agents 0-9, ``tab20``'s light shades for 10-19,
        repeating after 20 agents.

    Raises
    ------
    ValueError
        If ``i`` is negative or not an integer.

    Examples
    --------
    >>> agent_color(0), agent_color(3)
    ('#1f77b4', '#d62728')
    >>> agent_color(20) == agent_color(0)
    True
    """
    import operator

    try:
        index = operator.index(i)
    except TypeError:
        index = -1
    if isinstance(i, bool) or index < 0:
        raise ValueError(f"agent index must be a non-negative integer, got {i!r}")
    return _PALETTE[index % len(_PALETTE)]
