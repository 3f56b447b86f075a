"""``report/index.html``: the report as one static page, with audio players.

The page is the report's ``summary.md`` (tables, notes, figures) turned into HTML by a small
converter for the Markdown subset :mod:`benchmarks.report.core` writes (headings, pipe tables,
nested ``-`` lists, paragraphs, ``**bold**``, ``code``, ``[text](#anchor)`` links, ``![alt](file.png)``
and folded ``<details><summary>…</summary>`` … ``</details>`` blocks), followed by
a "Listen" section from :mod:`benchmarks.report.listening`.  Everything is HTML-escaped; the page
uses no script, no server, no network and no external CSS or fonts, so it works from
``file://``.  Paths in it are relative to ``report/``.
"""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from pathlib import Path

from benchmarks.report.listening import TARGET_LEVEL_DBFS, Listening, ListenOptions, build_listening
from benchmarks.report.splits import split_label

INDEX_NAME = "index.html"

_CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1300px; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 0.6em 0 1.2em; font-size: 0.85em; }
th, td { border: 1px solid #bbb; padding: 0.2em 0.45em; text-align: right; }
th { background: #eee; }
td:first-child, th:first-child { text-align: left; }
code { background: #f3f3f3; padding: 0 0.2em; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.4em 0; }
audio { width: 260px; height: 32px; vertical-align: middle; }
.note { color: #8a4b00; }
details summary { cursor: pointer; font-weight: bold; margin: 0.4em 0; }
h2, h3 { scroll-margin-top: 0.5em; }
section.listen { border-top: 2px solid #888; margin-top: 2em; }
"""

_IMAGE = re.compile(r"^!\[([^\]]*)\]\(([^)\s]+)\)$")
_DETAILS = re.compile(r"^<details><summary>(.*)</summary>$")  # a folded block opens (text escaped)
_SAFE_SRC = re.compile(r"^[A-Za-z0-9_.-]+$")  # a file beside the page, nothing else


def slug(title: str) -> str:
    """The anchor of a heading (GitHub's rule for the ASCII subset: lower case, spaces to
    hyphens, other punctuation dropped), so ``[x](#slug)`` links work in both renderers.

    >>> slug("Paired verdicts: vs `ss` (per noise)")
    'paired-verdicts-vs-ss-per-noise'
    """
    text = re.sub(r"[^\w\- ]", "", title.strip().lower())
    return text.replace(" ", "-")


def inline(text: str) -> str:
    """Escape ``text`` for HTML, then render ``**bold**``, ``*italic*``, ```code``` spans and
    links to in-page anchors or files beside the page (``[text](#anchor)``, ``[text](file.csv)``)."""
    out = html.escape(text, quote=True)
    out = re.sub(r"\[([^\]]+)\]\((#[\w-]+|[A-Za-z0-9_.-]+)\)", r'<a href="\2">\1</a>', out)
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    out = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", out)
    return re.sub(r"(?<![*\w])\*([^*\s][^*]*?)\*(?![*\w])", r"<em>\1</em>", out)


def _cells(line: str) -> list[str]:
    body = line.strip()[1:-1] if line.strip().endswith("|") else line.strip()[1:]
    # summary.md escapes a literal pipe inside a cell as "\|"
    parts = re.split(r"(?<!\\)\|", body)
    return [p.strip().replace("\\|", "|") for p in parts]


def _table(lines: Sequence[str]) -> str:
    head = _cells(lines[0])
    rows = [_cells(x) for x in lines[2:]] if len(lines) > 1 and set(lines[1]) <= set("|-: ") else [
        _cells(x) for x in lines[1:]
    ]
    th = "".join(f"<th>{inline(c)}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td>{inline(c)}</td>" for c in r) + "</tr>\n" for r in rows)
    return f"<table>\n<thead><tr>{th}</tr></thead>\n<tbody>\n{body}</tbody>\n</table>"


def _list(lines: Sequence[str]) -> str:
    """Nested ``-`` lists (two spaces per level)."""
    out: list[str] = []
    depth = -1
    for line in lines:
        level = (len(line) - len(line.lstrip(" "))) // 2
        item = inline(line.strip()[2:])
        if level > depth:
            out.append("<ul>" * (level - depth))
        else:
            out.append("</li>" + "</ul></li>" * (depth - level))
        out.append(f"<li>{item}")
        depth = level
    out.append("</li>" + "</ul></li>" * depth + "</ul>")
    return "".join(out)


def _image(match: re.Match) -> str:
    alt, src = match.group(1), match.group(2)
    if not _SAFE_SRC.match(src):
        return f"<p>{inline(match.group(0))}</p>"
    alt = html.escape(alt, quote=True)
    return f'<figure><img src="{html.escape(src, quote=True)}" alt="{alt}"><figcaption>{alt}</figcaption></figure>'


def markdown_to_html(text: str) -> str:
    """HTML for the Markdown subset ``summary.md`` uses (see the module docstring).

    >>> markdown_to_html("# A <b>\\n\\n| x |\\n|---|\\n| `1` |")
    '<h1 id="a-b">A &lt;b&gt;</h1>\\n<table>\\n<thead><tr><th>x</th></tr></thead>\\n<tbody>\\n<tr><td><code>1</code></td></tr>\\n</tbody>\\n</table>'
    """
    blocks: list[str] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        stripped = line.strip()
        if not stripped:
            i += 1
            continue
        heading = re.match(r"^(#{1,6})\s+(.*)$", stripped)
        if heading:
            n = len(heading.group(1))
            blocks.append(f'<h{n} id="{slug(heading.group(2))}">{inline(heading.group(2))}</h{n}>')
            i += 1
            continue
        details = _DETAILS.match(stripped)
        if details or stripped == "</details>":
            blocks.append(f"<details><summary>{inline(details.group(1))}</summary>" if details else "</details>")
            i += 1
            continue
        j = i
        if stripped.startswith("|"):
            while j < len(lines) and lines[j].strip().startswith("|"):
                j += 1
            blocks.append(_table([x.strip() for x in lines[i:j]]))
        elif stripped.startswith("- "):
            while j < len(lines) and lines[j].strip().startswith("- "):
                j += 1
            blocks.append(_list(lines[i:j]))
        elif _IMAGE.match(stripped):
            blocks.append(_image(_IMAGE.match(stripped)))
            j = i + 1
        else:
            # A paragraph: this line (always, so the loop advances) and the plain lines after it.
            j = i + 1
            while j < len(lines) and lines[j].strip() and not re.match(r"^(#|\||- |!\[|</?details>)", lines[j].strip()):
                j += 1
            blocks.append("<p>" + inline(" ".join(x.strip() for x in lines[i:j])) + "</p>")
        i = j
    return "\n".join(blocks)


def _fmt(value, digits: int) -> str:
    return "" if value is None else f"{float(value):.{digits}f}"


def listening_html(listening: Listening) -> str:
    """The "Listen" section: one table of players per condition."""
    parts = [
        '<section class="listen" id="listen">',
        "<h2>Listen</h2>",
        "<p>Each condition was re-rendered from the parameters recorded in the store (same "
        "scene, seed and data) and every system re-run on it. All clips of a condition are "
        f"loudness-matched to the same active speech level (ITU-T P.56 style, "
        f"{TARGET_LEVEL_DBFS:g} dBFS), then lowered together if one would clip; the "
        "gain column gives each clip's scaling. Metrics are the stored ones.</p>",
    ]
    if listening.audio_format:
        parts.append(f"<p>Audio: {html.escape(listening.audio_format)}, mono.</p>")
    parts += [f'<p class="note">{inline(n)}</p>' for n in listening.notes]
    for cond in listening.conditions:
        parts.append(f"<h3>{inline(cond.label)} <small><code>{html.escape(cond.condition_id)}</code></small></h3>")
        if cond.hint:
            parts.append(f"<p>{inline(cond.hint)}</p>")
        parts += [f'<p class="note">{inline(n)}</p>' for n in cond.notes]
        if not cond.clips:
            continue
        parts.append(
            "<table><thead><tr><th>signal</th><th>player</th><th>gain (dB)</th><th>SNR-I (dB)</th>"
            "<th>PESQ nb</th><th>STOI</th></tr></thead><tbody>"
        )
        any_row = next(iter(cond.rows.values()), {})
        for clip in cond.clips:
            row = cond.rows.get(clip.enhancer, {}) if clip.enhancer else {}
            if clip.role == "mixture":
                metrics = ("", _fmt(any_row.get("pesq_nb_in"), 2), _fmt(any_row.get("stoi_in"), 2))
            else:
                metrics = (_fmt(row.get("snr_i_db"), 1), _fmt(row.get("pesq_nb_out"), 2), _fmt(row.get("stoi_out"), 2))
            src = html.escape(clip.path or "", quote=True)
            player = (
                f'<audio controls preload="metadata" src="{src}" '
                f'data-duration-s="{clip.duration_s:.4f}"></audio>'
            )
            cells = [inline(clip.label), player, _fmt(clip.gain_db, 1), *metrics]
            parts.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
        parts.append("</tbody></table>")
    parts.append("</section>")
    return "\n".join(parts)


def write_index(
    report_dir: Path,
    summary_md: str,
    rows,
    *,
    store_dir: Path,
    listen: ListenOptions | None = None,
) -> list[Path]:
    """Write ``report_dir/index.html`` (and its clips); returns the written paths.

    Parameters
    ----------
    report_dir : Path
        The report folder (``summary.md`` and the figures are already there).
    summary_md : str
        The text of ``summary.md``.
    rows : sequence of mappings
        The store's rows (``condition_json``, ``enhancer_spec`` and sources are used).
    store_dir : Path
        The folder of ``results.sqlite`` (its ``runs`` table gives the data directory and
        the sweep's enhancer params).
    listen : ListenOptions, optional
        Which conditions get audio (default: :class:`ListenOptions`'s spread).
    """
    report_dir = Path(report_dir)
    rows = list(rows)
    listening = build_listening(rows, report_dir, Path(store_dir), listen or ListenOptions())
    body = markdown_to_html(summary_md)
    page = "\n".join(
        [
            "<!DOCTYPE html>",
            '<html lang="en"><head><meta charset="utf-8">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>scenesim benchmark report ({html.escape(split_label(rows))})</title>",
            f"<style>{_CSS}</style></head><body>",
            '<p><a href="#listen">Listen to examples</a> · <a href="summary.md">summary.md</a></p>',
            body,
            listening_html(listening),
            "</body></html>",
            "",
        ]
    )
    index = report_dir / INDEX_NAME
    index.write_text(page, encoding="utf-8")
    clips = [report_dir / c.path for cond in listening.conditions for c in cond.clips if c.path]
    return [index, *clips]


__all__ = ["INDEX_NAME", "listening_html", "markdown_to_html", "write_index"]
