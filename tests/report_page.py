"""A report page as the tests read it (and as its own footer check sees it)."""
import base64
from html.parser import HTMLParser

import cv2
import numpy as np


class ReportPage(HTMLParser):
    """text: the page's HTML; tables: name -> body rows as lists of cell texts; charts: name -> decoded image."""

    def __init__(self, text: str):
        super().__init__()
        self.text, self.tables, self.charts, self._rows, self._body = text, {}, {}, None, False
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self._rows = self.tables.setdefault(attrs["data-table"], [])
        elif tag == "tbody":
            self._body = True
        elif tag == "tr" and self._rows is not None and self._body:
            self._rows.append([])
        elif tag == "td" and self._rows:
            self._rows[-1].append("")
        elif tag == "img" and attrs.get("class") == "chart":
            png = np.frombuffer(base64.b64decode(attrs["src"].split(",", 1)[1]), np.uint8)
            self.charts[attrs["data-chart"]] = cv2.imdecode(png, cv2.IMREAD_COLOR)

    def handle_endtag(self, tag):
        if tag == "tbody":
            self._body = False
        elif tag == "table":
            self._rows = None

    def handle_data(self, data):
        if self._rows and self._rows[-1] and self._body:
            self._rows[-1][-1] += data

    def column(self, table: str, header_index: int) -> list[str]:
        return [row[header_index] for row in self.tables[table]]
