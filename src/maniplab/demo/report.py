"""The demo's report: one self-contained HTML page (figures embedded, videos linked).

A report is a list of sections; each says in a sentence what was done and what it shows, gives
its key figures as a small table, and embeds its figures (PNG, base64) or links its videos.
"""

from __future__ import annotations

import base64
import dataclasses
import html
from collections.abc import Sequence
from pathlib import Path

from maniplab.atomic import write_text


@dataclasses.dataclass
class Section:
    """One result of the demo.

    Attributes:
        title: heading.
        sentence: what was done and what it shows, one or two sentences.
        figures: key figures as (name, value with unit) pairs.
        images: PNG files to embed (their file name is the caption).
        videos: video files to link (relative to the report).
        posters: per video, a PNG of its last frame shown as its preview (fewer posters than
            videos: the rest are plain links).
        pages: self-contained HTML pages (3D replays) embedded in the report, each also linked.
    """

    title: str
    sentence: str
    figures: Sequence[tuple[str, str]] = ()
    images: Sequence[Path] = ()
    videos: Sequence[Path] = ()
    posters: Sequence[Path] = ()
    pages: Sequence[Path] = ()


_STYLE = """
body { font-family: system-ui, -apple-system, 'Segoe UI', sans-serif; max-width: 1100px;
       margin: 2em auto; padding: 0 1em; color: #1d232a; line-height: 1.45; }
h1 { font-size: 1.7em; margin-bottom: 0.2em; } h2 { font-size: 1.25em; margin-top: 2em;
  border-bottom: 1px solid #d8dee4; padding-bottom: 0.2em; }
.lead { color: #57606a; } table { border-collapse: collapse; margin: 0.6em 0; }
td, th { border: 1px solid #d8dee4; padding: 0.25em 0.7em; text-align: left; }
th { background: #f6f8fa; } figure { margin: 0.8em 0; } img { max-width: 100%; }
figcaption { color: #57606a; font-size: 0.85em; } .summary td:first-child { font-weight: 600; }
a.video img { border: 1px solid #d8dee4; }
iframe.replay { width: 100%; height: 520px; border: 1px solid #d8dee4; }
"""


def write_report(path: Path, title: str, lead: str, summary: Sequence[tuple[str, str]],
                 sections: Sequence[Section]) -> Path:
    """Write the report to ``path`` (atomically) and return it.

    Args:
        path: the HTML file; videos are linked relative to its folder.
        title: page title.
        lead: one paragraph under the title.
        summary: the key figures of the whole run, (name, value) pairs, shown first.
        sections: the results in order.
    """
    body = [f"<h1>{_e(title)}</h1>", f"<p class='lead'>{_e(lead)}</p>",
            "<table class='summary'>" + "".join(_row(k, v) for k, v in summary) + "</table>"]
    body += [_section(section, path.parent) for section in sections]
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>{_e(title)}</title><style>{_STYLE}</style></head><body>"
            + "\n".join(body) + "</body></html>\n")
    write_text(path, page)
    return path


def _section(section: Section, folder: Path) -> str:
    parts = [f"<h2>{_e(section.title)}</h2>", f"<p>{_e(section.sentence)}</p>"]
    if section.figures:
        parts.append("<table>" + "".join(_row(k, v) for k, v in section.figures) + "</table>")
    for k, video in enumerate(section.videos):
        link = _e(_relative(video, folder))
        poster = (f"<img src='{_data_uri(section.posters[k])}' alt='last frame of {link}'>"
                  if k < len(section.posters) else link)
        parts.append(f"<figure><a class='video' href='{link}'>{poster}</a>"
                     f"<figcaption>video: <a href='{link}'>{link}</a></figcaption></figure>")
    for page in section.pages:  # inline (srcdoc): the report stays one file that works offline
        link = _e(_relative(page, folder))
        parts.append(f"<figure><iframe class='replay' title='{link}' srcdoc='"
                     f"{_e(page.read_text(encoding='utf-8'))}'></iframe>"
                     f"<figcaption>3D replay (drag to orbit; play, pause, scrub and speed below "
                     f"it): <a href='{link}'>{link}</a></figcaption></figure>")
    for image in section.images:
        parts.append(f"<figure><img src='{_data_uri(image)}' alt='{_e(image.name)}'>"
                     f"<figcaption>{_e(image.name)}</figcaption></figure>")
    return "\n".join(parts)


def _row(name: str, value: str) -> str:
    return f"<tr><td>{_e(name)}</td><td>{_e(value)}</td></tr>"


def _data_uri(image: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(image.read_bytes()).decode("ascii")


def _relative(path: Path, folder: Path) -> str:
    try:
        return path.resolve().relative_to(folder.resolve()).as_posix()
    except ValueError:
        return path.resolve().as_uri()


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)
