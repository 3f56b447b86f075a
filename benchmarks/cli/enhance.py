"""`scenesim enhance` (being written)."""


def add_parser(subparsers):
    p = subparsers.add_parser("enhance", help="(not yet available)")
    p.set_defaults(func=lambda args: (_ for _ in ()).throw(SystemExit("scenesim enhance: not yet available")))
