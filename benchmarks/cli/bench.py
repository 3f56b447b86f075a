"""`scenesim bench` (being written)."""


def add_parser(subparsers):
    p = subparsers.add_parser("bench", help="(not yet available)")
    p.set_defaults(func=lambda args: (_ for _ in ()).throw(SystemExit("scenesim bench: not yet available")))
