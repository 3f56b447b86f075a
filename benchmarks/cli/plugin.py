"""``scenesim plugin new NAME --dest DIR``: start an enhancer plugin package (benchmarks.cli.plugin_scaffold)."""

from __future__ import annotations

from pathlib import Path


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "plugin",
        help="start a new enhancer plugin package",
        description="Enhancer plugins: pip-installable packages registered through the "
        "'scenesim.enhancers' entry point.",
    )
    sub = p.add_subparsers(dest="plugin_command", metavar="ACTION", required=True)
    new = sub.add_parser(
        "new",
        help="write a pip-installable plugin package (enhancer, pyproject.toml, conformance tests)",
        description="Write a plugin package for the enhancer NAME into DIR (new or empty): "
        "pyproject.toml with the scenesim.enhancers entry point, an enhancer template with "
        "frozen Params, tags, batch/streaming processing and replay, and tests running the "
        "conformance suite.",
    )
    new.add_argument("name", metavar="NAME", help="registry name, e.g. my-denoiser")
    new.add_argument("--dest", type=Path, required=True, metavar="DIR", help="new or empty directory")
    new.set_defaults(func=_new)


def _new(args) -> int:
    from benchmarks.cli.plugin_scaffold import module_name, new_plugin

    files = new_plugin(args.name, args.dest)
    for f in files:
        print(f)
    print(
        f"\nNext: pip install -e {args.dest} && python -m pytest {args.dest / 'tests'}\n"
        f"then '{args.name}' appears in 'scenesim bench list'; edit "
        f"{args.dest / module_name(args.name) / 'enhancer.py'} to put your algorithm in."
    )
    return 0
