"""`scenesim data` (being written)."""


def add_parser(subparsers):
    p = subparsers.add_parser("data", help="(not yet available)")
    p.set_defaults(func=lambda args: (_ for _ in ()).throw(SystemExit("scenesim data: not yet available")))
