"""The page script's inputs: the hover texts travel as attributes (the page's text is unchanged), escaped."""

from __future__ import annotations

import html

import viser

from console.views.page_a11y import PAGE_SCRIPT, element_id, hint_spans


def test_hint_spans_carry_the_text_in_an_attribute_escaped() -> None:
    server = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        b = server.gui.add_button("Land here")
        out = hint_spans([(b, 'cannot land here: "desk" <1> & co')])
        assert out == (f'<span hidden data-mn-hint-for="{element_id(b)}" '
                       'data-mn-hint="cannot land here: &quot;desk&quot; &lt;1&gt; &amp; co"></span>')
        assert html.unescape(out).count("cannot land here") == 1 and ">cannot" not in out  # no text content
    finally:
        server.stop()


def test_the_script_links_labels_and_copies_hints_once_per_page() -> None:
    assert "window.__morphonaviA11y" in PAGE_SCRIPT  # installed once however often it is sent
    assert "aria-labelledby" in PAGE_SCRIPT and "data-mn-hint" in PAGE_SCRIPT and "'title'" in PAGE_SCRIPT
    assert "fetch(" not in PAGE_SCRIPT and "XMLHttpRequest" not in PAGE_SCRIPT  # no network
