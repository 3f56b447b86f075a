"""`scenesim rir` (being written)."""


def add_parser(subparsers):
    p = subparsers.add_parser("rir", help="(not yet available)")
    p.set_defaults(func=lambda args: (_ for _ in ()).throw(SystemExit("scenesim rir: not yet available")))
