"""``scenesim data list | prepare``: show the data recipes and the resolved data source, run a recipe."""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "data",
        help="list data recipes and the data source in use; prepare a data directory",
        description="Speech and noise data: built-in artificial voice and synthesized noises, "
        "local folders (speech/, noise/<type>_*.wav), CMU ARCTIC download, NOISEX-92 conversion.",
    )
    sub = p.add_subparsers(dest="data_command", metavar="ACTION", required=True)

    lst = sub.add_parser("list", help="recipes, and the data source / noise types that would be used")
    lst.add_argument("--data-dir", type=Path, default=None, metavar="DIR",
                     help="data directory to inspect (default: $SCENESIM_DATA, else built-in)")
    lst.set_defaults(func=_list)

    prep = sub.add_parser(
        "prepare",
        help="run a recipe into a data directory",
        description="Run a data recipe.  artificial-voice: write the built-in voices/noises; "
        "local: validate --src (and convert into --dest); cmu-arctic: download (needs internet); "
        "noisex92: convert the NOISEX-92 files in --src.",
    )
    prep.add_argument("recipe", metavar="RECIPE", help="artificial-voice, local, cmu-arctic or noisex92")
    prep.add_argument("--dest", default=None, metavar="DIR",
                      help="output data directory (default: $SCENESIM_CACHE/<recipe> or ~/.cache/scenesim/<recipe>)")
    prep.add_argument("--src", type=Path, default=None, metavar="DIR", help="input folder (local, noisex92)")
    prep.add_argument("--talkers", nargs="+", default=None, metavar="T", help="CMU ARCTIC voices, e.g. bdl slt")
    prep.add_argument("--utterances", nargs="+", default=None, metavar="ID", help="CMU ARCTIC ids, e.g. a0001 a0002")
    prep.add_argument("--base-url", default=None, metavar="URL", help="CMU ARCTIC mirror (default: festvox.org)")
    prep.add_argument("--fs", type=int, default=None, metavar="HZ", help="sampling rate of written files")
    prep.set_defaults(func=_prepare)


def _list(args: argparse.Namespace) -> int:
    import data_recipes

    print("Data recipes:")
    for recipe in data_recipes.list_recipes():
        print(f"  {recipe.name:<17} {recipe.summary}")
    source = data_recipes.open_data(args.data_dir)  # its warnings: main's console lines
    print(f"\nData source: {source.description}")
    local = set(source.local_noise_types)
    print("Noise types: " + ", ".join(
        f"{t} ({'file' if t in local else 'synthesized'})" for t in source.noise_types()))
    return 0


#: Recipes that read a folder of the user's, and what the folder holds.
_NEEDS_SRC = {"local": "the folder to validate, with speech/ and noise/", "noisex92": "the NOISEX-92 files"}


def _prepare(args: argparse.Namespace) -> int:
    import data_recipes
    from benchmarks.cli.checks import options_named, prepare_out_dir
    from scenesim.errors import ConfigError

    if args.src is None and args.recipe in _NEEDS_SRC:
        raise ConfigError(f"the {args.recipe} recipe needs --src DIR ({_NEEDS_SRC[args.recipe]}): "
                          f"scenesim data prepare {args.recipe} --src DIR")
    if args.dest is not None:
        args.dest = prepare_out_dir("--dest", args.dest, create=False)
    options = {}
    if args.src is not None:
        options["src"] = args.src
    if args.talkers is not None:
        options["talkers"] = tuple(args.talkers)
    if args.utterances is not None:
        options["utterances"] = tuple(args.utterances)
    if args.base_url is not None:
        options["base_url"] = args.base_url
    if args.fs is not None:
        options["fs"] = args.fs
    with options_named({"src": "--src", "dest": "--dest", "talkers": "--talkers", "utterances": "--utterances",
                        "base_url": "--base-url", "fs": "--fs"}):
        manifest = data_recipes.prepare(args.recipe, args.dest, **options)  # warnings: main's console lines
    files = manifest.get("files") or (manifest.get("speech", []) + manifest.get("noise", []))
    where = manifest.get("dest") or (str(args.dest) if args.dest else manifest.get("root", ""))
    print(f"{args.recipe}: {len(files)} file(s) in {where}")
    for bad in manifest.get("bad", []):
        print(f"  skipped {bad['file']}: {bad['reason']}")
    if args.dest is None and args.recipe == "local":
        print(json.dumps(manifest, indent=2))
    return 0
