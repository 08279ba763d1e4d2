"""The report's HTML twin: the Markdown page rendered by the `markdown` package."""

from __future__ import annotations

import html

import markdown

STYLE = ("body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}"
         "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;"
         "padding:.2em .6em;text-align:right}td:first-child,th:first-child{text-align:left}"
         "img{max-width:100%}")


def markdown_to_html(md: str, title: str = "granwave report") -> str:
    """A standalone HTML page of the Markdown text (pipe tables included)."""
    body = markdown.markdown(md, extensions=["tables"], output_format="html")
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\">\n"
            f"<title>{html.escape(title)}</title>\n<style>{STYLE}</style>\n</head><body>\n"
            f"{body}\n</body></html>\n")
