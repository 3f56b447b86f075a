"""``scenesim listen DIR``: a blind P.835 or MUSHRA listening test from a sweep's stored clips."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from benchmarks.cli.bench import _nonneg_int, _positive_int

_EPILOG = """\
examples:
  scenesim listen runs/phone                              # P.835, the report's conditions
  scenesim listen runs/phone --method mushra --systems eb-robust-ss ss --listener ana
  scenesim listen runs/phone --host 0.0.0.0 --port 8835   # colleagues on the same network

The page asks each listener for a name (unless --listener is given); every rating is saved to
DIR/results.sqlite (table ratings) the moment it is given, and a listener who reopens the page
with the same name resumes where they stopped.  Their order is drawn from their name and --seed.
`scenesim bench report DIR` analyses the ratings (section "Listening test").  See docs/listening.md.
"""


def _port(text: str) -> int:
    value = _nonneg_int(text)
    if value > 65535:
        raise argparse.ArgumentTypeError(f"expected a port 0..65535 (0: any free port), got {text!r}")
    return value


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "listen",
        help="serve a blind P.835 or MUSHRA listening test of a sweep's clips; ratings go to its store",
        description="Build a blind listening test (ITU-T P.835 or ITU-R BS.1534 MUSHRA) from the clips "
        "a sweep stored, serve it from a local web server and save each rating to the sweep's store.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("dir", type=Path, metavar="DIR", help="the sweep's output folder (results.sqlite)")
    p.add_argument("--method", choices=("p835", "mushra"), default="p835", help="default: p835")
    p.add_argument("--conditions", nargs="+", default=(), metavar="ID", help="condition ids (default: the report's picker)")
    p.add_argument("--count", type=_positive_int, default=None, metavar="N", help="conditions the picker chooses (default 6)")
    p.add_argument("--systems", nargs="+", default=(), metavar="NAME", help="enhancers to rate (default: all of the sweep's)")
    p.add_argument("--listener", default=None, metavar="NAME", help="the only listener (default: the page asks for a name)")
    p.add_argument("--seed", type=_nonneg_int, default=0, metavar="S", help="mixed with each name into its order (default 0)")
    p.add_argument("--port", type=_port, default=8835, metavar="N", help="default 8835 (0: any free port)")
    p.add_argument("--host", default="127.0.0.1", metavar="ADDRESS", help="bind address (default 127.0.0.1: this machine only)")
    p.set_defaults(func=_listen)


def _listen(args) -> int:
    from benchmarks.report.listen_server import (
        ListeningTest,
        check_listener,
        make_server,
        server_url,
    )
    from benchmarks.report.listen_test import build_material
    from benchmarks.store.sqlite import ResultStore

    listener = None if args.listener is None else check_listener(args.listener)
    material = build_material(args.dir, method=args.method, conditions=args.conditions,
                              systems=args.systems, count=args.count)  # fmt: skip
    with ResultStore.open(args.dir):  # creates the ratings table (or refuses a newer layout) before serving
        pass
    test = ListeningTest(material, args.dir, seed=args.seed, listener=listener)
    server = make_server(test, host=args.host, port=args.port)
    n_stimuli = sum(len(files) for files in material.clips.values())
    print(f"scenesim listen: {args.method} test of {len(material.clips)} condition(s), {n_stimuli} clips; "
          f"open {server_url(server)} (Ctrl-C stops)", flush=True)  # fmt: skip
    for note in material.notes:
        print(f"scenesim: note: {note}", file=sys.stderr)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
    with ResultStore.open(args.dir, readonly=True) as store:
        ratings = store.ratings()
    listeners = sorted({r["listener"] for r in ratings})
    print(f"scenesim listen: stopped; {test.saved} rating(s) saved this session, {len(ratings)} in "
          f"{Path(args.dir) / 'results.sqlite'} (table ratings) from {len(listeners)} listener(s)"
          + (f": {', '.join(listeners)}" if listeners else ""))  # fmt: skip
    return 0
