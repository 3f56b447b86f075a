"""``scenesim thesis search | evaluate``: the search over the thesis' lost details, its held-out error
and identifiability; or the ``thesis-fit`` reading scored on one data set (benchmarks.thesis.command)."""

from __future__ import annotations

import argparse


def add_parser(subparsers) -> None:
    from benchmarks.thesis.command import SEARCH_EPILOG, add_evaluate, add_search, evaluate, search

    p = subparsers.add_parser(
        "thesis",
        help="search the thesis' lost simulation details (held-out error, identifiability); score the fit",
        description="The source thesis' tables 7.1-7.9 against readings of its lost simulation details.",
    )
    sub = p.add_subparsers(dest="thesis_command", metavar="ACTION", required=True)
    s = sub.add_parser("search", help="choose a reading on dev material, score it held out, bootstrap the top ones",
                       description="Search the readings on dev material; held-out error and identifiability.",
                       epilog=SEARCH_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_search(s)
    s.set_defaults(func=search)
    e = sub.add_parser("evaluate", help="score the thesis-fit reading (BEST) on all 54 cells of this data",
                       description="Score the thesis-fit preset's reading on all 54 cells of the chosen material.")
    add_evaluate(e)
    e.set_defaults(func=evaluate)
