"""`scenesim simulate` (being written)."""


def add_parser(subparsers):
    p = subparsers.add_parser("simulate", help="(not yet available)")
    p.set_defaults(func=lambda args: (_ for _ in ()).throw(SystemExit("scenesim simulate: not yet available")))
