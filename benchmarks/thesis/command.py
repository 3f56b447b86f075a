"""``scenesim thesis search`` / ``scenesim thesis evaluate`` (and ``python -m benchmarks.thesis.search``):
the options and the handlers, shared by both ways in.

Every input is checked before any work (:mod:`benchmarks.thesis.options`); a bad one is one
:class:`scenesim.errors.ParameterError` line.  Long runs print a progress line per stage.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from benchmarks.thesis.options import check_count, check_duration, open_checked
from benchmarks.thesis.results import DEFAULT_OUT

SEARCH_EPILOG = """\
The search chooses a reading on dev material (stages: coarse EB grid, PESQ on the best families,
refinement, the SS unknowns with the three output-SNR measurements), scores it on test material
and on the other family of tables (babble -> factory+wind and back), and bootstraps the top
readings over --seeds seeds for the set the data cannot tell apart.  DIR/thesis_search.json and
DIR/thesis_identifiability.csv hold the results; `scenesim bench report` reads the JSON from
$SCENESIM_THESIS_SEARCH, next to the store, or ./thesis-search/.
"""


def add_common(p: argparse.ArgumentParser) -> None:
    """The options both actions share: data, aliases, duration, seed, PESQ."""
    p.add_argument("--data-dir", type=Path, default=None, metavar="DIR",
                   help="speech/noise directory (default: built-in data)")
    p.add_argument("--alias", nargs="+", action="extend", default=[], metavar="NOISE=TYPE",
                   help="play a thesis noise with the data's TYPE, e.g. babble=cafe factory=machinery")
    p.add_argument("--duration", default="8", metavar="S", help="seconds of speech per cell, 1-60 (default 8)")
    p.add_argument("--seed", default="0", metavar="S", help="utterance / noise-segment seed (default 0)")
    p.add_argument("--no-pesq", action="store_true", help="SNR-I only (no PESQ)")


def add_search(p: argparse.ArgumentParser) -> None:
    add_common(p)
    p.add_argument("--out", type=Path, default=Path(DEFAULT_OUT), metavar="DIR",
                   help=f"where thesis_search.json goes (default ./{DEFAULT_OUT})")
    p.add_argument("--top", default="6", metavar="N", help="reading families scored with PESQ, 1-20 (default 6)")
    p.add_argument("--seeds", default="5", metavar="N", help="seeds of the identifiability bootstrap, 2-10 (default 5)")
    p.add_argument("--boot", default="1000", metavar="N", help="bootstrap resamples, 100-20000 (default 1000)")
    p.add_argument("--ident-top", default="24,12", metavar="EB,SS",
                   help="readings of each block bootstrapped, 2-200 each (default 24,12)")
    p.add_argument("--grid", choices=("full", "small"), default="full",
                   help="coarse EB grid: full factorial (1152) or small (see benchmarks.thesis.search.SMALL)")


def add_evaluate(p: argparse.ArgumentParser) -> None:
    add_common(p)
    p.add_argument("--split", choices=("all", "dev", "test"), default="all", help="material (default all)")


def _log(text: str) -> None:
    print(f"[thesis] {text}", flush=True)


def _common(args) -> dict:
    duration = check_duration(args.duration)
    from benchmarks.thesis.options import MAX_SEED

    seed = check_count(args.seed, "--seed", 0, MAX_SEED)
    aliases = open_checked(args.data_dir, args.alias)
    return {"duration_s": duration, "seed": seed, "aliases": aliases}


def search(args) -> int:
    """Run the protocol (search, held-out error, identifiability) and write ``--out``."""
    from benchmarks.thesis import readings as S
    from benchmarks.thesis.protocol import run_protocol
    from benchmarks.thesis.results import protocol_lines, write_results

    common = _common(args)
    top = check_count(args.top, "--top", 1, 20)
    n_seeds = check_count(args.seeds, "--seeds", 2, 10)
    n_boot = check_count(args.boot, "--boot", 100, 20000)
    parts = str(args.ident_top).split(",")
    if len(parts) != 2:
        from scenesim.errors import ParameterError

        raise ParameterError("--ident-top", args.ident_top, "EB,SS: two integers, e.g. 24,12")
    top_eb, top_ss = (check_count(v, "--ident-top", 2, 200) for v in parts)
    out = _out_dir(args.out)
    grid = S.COARSE if args.grid == "full" else S.SMALL
    _log(f"data: {args.data_dir or 'built-in'} {common['aliases'] or ''}; choose on dev, score on test")
    t0 = time.perf_counter()
    result = run_protocol(args.data_dir, **common, n_seeds=n_seeds, with_pesq=not args.no_pesq,
                          search={"grid": grid, "top": top}, top_eb=top_eb, top_ss=top_ss, n_boot=n_boot,
                          log=_log, keep_search=True)
    fit = result.pop("_search")
    print("\n".join(S.report_lines(fit)))
    print()
    print("\n".join(protocol_lines(result)))
    for path in write_results(result, out):
        print(f"wrote {path}")
    _log(f"done in {time.perf_counter() - t0:.0f} s")
    return 0


def evaluate(args) -> int:
    """Score the ``thesis-fit`` preset's reading on all 54 cells of the chosen material."""
    from benchmarks.thesis import readings as S

    common = _common(args)
    cells = S.Cells(args.data_dir, split=args.split, **common)
    _log(f"data: {args.data_dir or 'built-in'} {common['aliases'] or ''}, {args.split} material")
    print("\n".join(S.evaluate_lines(cells, S.BEST, with_pesq=not args.no_pesq)))
    return 0


def _out_dir(path: Path) -> Path:
    """``--out`` created and writable (one ParameterError line otherwise)."""
    from scenesim.errors import ParameterError

    if str(path).strip() == "" or (path.exists() and not path.is_dir()):
        raise ParameterError("--out", str(path), "a directory path (not an existing file)")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError("--out", str(path), f"a directory that can be created ({exc.strerror})") from None
    return path


def standalone(argv=None) -> int:
    """``python -m benchmarks.thesis.search [--evaluate] ...``: the same handlers, the same one-line errors."""
    from scenesim.errors import ScenesimError

    ap = argparse.ArgumentParser(prog="python -m benchmarks.thesis.search",
                                 description="scenesim thesis search / evaluate (see `scenesim thesis --help`)",
                                 epilog=SEARCH_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_search(ap)
    ap.add_argument("--split", choices=("all", "dev", "test"), default="all", help="--evaluate's material")
    ap.add_argument("--evaluate", action="store_true", help="no search: score the preset's reading (BEST)")
    args = ap.parse_args(argv)
    try:
        return evaluate(args) if args.evaluate else search(args)
    except ScenesimError as exc:
        print(f"scenesim: error: {exc}", file=sys.stderr)
        return 2
