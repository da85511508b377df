"""The page's texts: exactly those of texts.PAGE_TEXTS (which gettext extracts into gidabot_gui's catalogs), every
one translated into Basque and Spanish with its placeholders."""

from __future__ import annotations

import re

from gidabot_web.dashboard.app import STATIC
from gidabot_web.dashboard.texts import PAGE_TEXTS, catalogs

STRING = r'"((?:[^"\\]|\\.)*)"'


def used_by_the_page() -> set[str]:
    """Texts the page translates: ``t("...")``, the fallbacks ``X[k] || "..."`` and the values of its ``*_TEXTS``
    tables in dashboard.js; ``data-t`` and ``data-tp`` attributes in index.html."""
    js = (STATIC / "dashboard.js").read_text(encoding="utf-8")
    html = (STATIC / "index.html").read_text(encoding="utf-8")
    found = set(re.findall(r"\bt\(\s*" + STRING, js)) | set(re.findall(r"\|\|\s*" + STRING + r"\s*[,)]", js))
    for table in re.findall(r"const [A-Z_]+_TEXTS = \{(.*?)\};", js, re.S):
        found |= set(re.findall(r":\s*" + STRING, table))
    found |= set(re.findall(r'data-tp?="([^"]*)"', html))
    return found


def test_the_page_uses_exactly_the_marked_texts() -> None:
    used = used_by_the_page()
    assert used == set(PAGE_TEXTS), (f"not marked in texts.py: {sorted(used - set(PAGE_TEXTS))}; "
                                     f"marked but unused: {sorted(set(PAGE_TEXTS) - used)}")
    assert len(PAGE_TEXTS) == len(set(PAGE_TEXTS))


def test_every_text_is_translated_with_its_placeholders() -> None:
    cats = catalogs()
    same = {"{n} s", "{n} min", "{ms} ms", "Robot"}
    for language in ("eu", "es"):
        for text in PAGE_TEXTS:
            out = cats[language][text]
            assert out and (out != text or text in same), (language, text)
            assert sorted(re.findall(r"\{(\w+)\}", out)) == sorted(re.findall(r"\{(\w+)\}", text)), (language, text)
    assert all(cats["en"][t] == t for t in PAGE_TEXTS)
