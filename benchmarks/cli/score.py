"""``scenesim score DEG... [--ref REF] [--out CSV]``: score recordings, one CSV row per file.

DEG and REF are files or folders (a folder's ``.wav``/``.flac`` files, paired with the
reference folder by file name).  Every metric that applies is computed
(:mod:`benchmarks.metrics.scoring`): with a reference PESQ (narrow-band and wide-band, MOS-LQO and
raw), STOI, ESTOI, SI-SDR and segmental SNR; always SRMR and DNSMOS P.835 (when the
``[dnsmos]`` extra is installed).  The CSV goes to ``--out`` or to standard output.
"""

from __future__ import annotations

import csv
import importlib.util
import sys
from pathlib import Path

from benchmarks.cli.checks import check_out_file
from benchmarks.metrics.scoring import INTRUSIVE, NON_INTRUSIVE, score_files

_FIRST = ("file", "reference", "fs", "duration_s")


def add_parser(subparsers):
    p = subparsers.add_parser(
        "score",
        help="score recordings (PESQ, STOI, SI-SDR, ... with --ref; SRMR, DNSMOS always)",
        description=(
            "Score processed speech: files or folders (folders pair with the --ref folder by "
            "file name). With --ref: PESQ nb/wb (MOS-LQO and raw), STOI, ESTOI, SI-SDR, "
            "segmental SNR; always: SRMR and DNSMOS P.835 (pip install -e '.[dnsmos]'). "
            "One CSV row per file."
        ),
    )
    p.add_argument("degraded", nargs="+", metavar="DEG", help="processed audio file(s) or folder(s)")
    p.add_argument("--ref", default=None, metavar="REF", help="clean reference file or folder (same names)")
    p.add_argument("--out", default=None, metavar="CSV", help="write the table here (default: standard output)")
    p.add_argument("--channel", type=int, default=None, metavar="I",
                   help="score channel I of multichannel files (default: files must be mono)")
    p.add_argument("--trim", action="store_true",
                   help="score the common first samples when a file and its reference differ in length")
    p.add_argument("--no-dnsmos", action="store_true", help="skip DNSMOS (the slowest metric)")
    p.set_defaults(func=run)
    return p


def _write(rows: list[dict], stream) -> None:
    columns = [*_FIRST, *INTRUSIVE, *NON_INTRUSIVE, "error"]
    writer = csv.DictWriter(stream, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


def run(args) -> int:
    out = check_out_file("--out", args.out) if args.out else None
    dnsmos = not args.no_dnsmos and importlib.util.find_spec("speechmos") is not None
    if not args.no_dnsmos and not dnsmos:
        print("scenesim: DNSMOS skipped (not installed: pip install -e '.[dnsmos]')", file=sys.stderr)
    rows = score_files(args.degraded, args.ref, channel=args.channel, trim=args.trim, dnsmos=dnsmos)
    if out is None:
        _write(rows, sys.stdout)
        return 0
    with open(Path(out), "w", newline="") as stream:
        _write(rows, stream)
    print(f"{len(rows)} file(s) scored -> {out}")
    return 0
