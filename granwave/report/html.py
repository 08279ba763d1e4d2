"""The report's HTML twin: the Markdown page rendered by the `markdown` package."""

from __future__ import annotations

import html

import markdown
import nh3

#: The tags and attributes the report's Markdown renders to (pipe tables, links, images, the
#: sections' anchors <a id=...>); anything else in the page is user text or a file's name that
#: reached the Markdown, and nh3 (the ammonia sanitizer) removes it: no markup of theirs runs.
TAGS = {"h1", "h2", "h3", "h4", "h5", "h6", "p", "a", "img", "em", "strong", "code", "pre", "ul", "ol",
        "li", "table", "thead", "tbody", "tr", "th", "td", "hr", "br", "blockquote", "sup", "sub"}
ATTRIBUTES = {"a": {"href", "id", "title"}, "img": {"src", "alt", "title"}, "th": {"align"},
              "td": {"align"}}

STYLE = ("body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}"
         "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
         "padding:.2em .6em;text-align:right}td:first-child,th:first-child{text-align:left}"
         "img{max-width:100%}")


def markdown_to_html(md: str, title: str = "granwave report") -> str:
    """A standalone HTML page of the Markdown text (pipe tables included)."""
    page = markdown.markdown(md, extensions=["tables"], output_format="html",
                             extension_configs={"tables": {"use_align_attribute": True}})
    body = nh3.clean(page, tags=TAGS,
                     attributes=ATTRIBUTES, url_schemes={"http", "https", "mailto"}, link_rel=None)
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">\n"
            f"<title>{html.escape(title)}</title>\n<style>{STYLE}</style>\n</head><body>\n"
            f"{body}\n</body></html>\n")
