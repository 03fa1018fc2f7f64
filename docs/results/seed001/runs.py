"""Helpers shared by seed 001's table scripts (tables.py, ablate_gaps.py, domega.py)."""
from statistics import mean


def group_of(leader, sizes):
    """The start group (0-based) a leader's id falls in, robots numbered group after group."""
    end = 0
    for g, s in enumerate(sizes):
        end += s
        if leader < end:
            return g
    return len(sizes) - 1


def avg(xs):
    """The mean of the values that are not None, or None."""
    xs = [x for x in xs if x is not None]
    return mean(xs) if xs else None
