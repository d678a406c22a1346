"""Accessibility fixes for the console's page: every field linked to its label, every button's hover text shown.

The console's GUI is viser's (React + Mantine, version pinned in pyproject). Two things its client does not do,
checked in its shipped source (``viser/client/src/components``) and in the browser:

- **Text fields are not linked to their labels.** viser draws each labelled field as
  ``<label for=UUID>`` beside the input, but gives only number, dropdown, checkbox and slider inputs the id
  ``UUID``; a text input (``Goal x [m]``, ``Find``, ``Name``) gets Mantine's own generated id, so screen
  readers and tests that find fields by label (Playwright's ``get_by_label("Goal x [m]")``) cannot find it.
  A slider's ``for`` names its wrapper, not the slider thumb.
- **Buttons never show their hint.** viser's button component ignores ``hint`` (no tooltip), so a disabled
  button could not say why it is off.

viser has no option for either, so the console sends one small page script (:data:`PAGE_SCRIPT`, as viser's
own message for page scripts, kept for tabs that connect later) that, whenever the panel changes:

1. gives every input whose ``<label for>`` does not reach it ``aria-labelledby`` = that label (the label gets
   an id) — the standard ARIA link, so the accessible name is the label's text;
2. copies each button's hover text from a hidden, empty ``<span data-mn-hint-for=UUID data-mn-hint=TEXT>`` (an
   attribute, so the page's text is unchanged; written by the views with
   :func:`hint_spans`, through viser's normal GUI state, so every tab shows the current text) into the
   button's ``title`` (the browser's hover tooltip, also on a disabled button) and ``aria-description``.

Nothing else on the page is changed; no network access. Without the script the console works as before.
"""

from __future__ import annotations

import html
from typing import Any, Iterable

PAGE_SCRIPT = r"""
if (!window.__morphonaviA11y) {
  window.__morphonaviA11y = true;
  const FIELD = 'input:not([type=hidden]), textarea, [role=slider]';
  const linkLabels = () => {
    document.querySelectorAll('label[for]').forEach((label) => {
      const target = document.getElementById(label.htmlFor);
      if (target && target.matches('input, textarea, select')) return;  // linked already
      let row = label.closest('.mantine-Flex-root');
      if (!row) row = label.parentElement && label.parentElement.parentElement && label.parentElement.parentElement.parentElement;
      if (!row || !row.lastElementChild) return;
      const field = row.lastElementChild.querySelector(FIELD);
      const id = label.id || (label.id = 'mn-label-' + label.htmlFor);
      const el = field || row.lastElementChild;
      if (!field) el.setAttribute('role', 'group');
      if (el.getAttribute('aria-labelledby') !== id) el.setAttribute('aria-labelledby', id);
    });
  };
  const showHints = () => {
    document.querySelectorAll('[data-mn-hint-for]').forEach((span) => {
      const button = document.getElementById(span.getAttribute('data-mn-hint-for'));
      const text = span.getAttribute('data-mn-hint') || '';
      if (!button || button.getAttribute('title') === text) return;
      button.setAttribute('title', text);
      button.setAttribute('aria-description', text);
    });
  };
  let pending = false;
  const fix = () => {
    pending = false;
    try { linkLabels(); showHints(); } catch (e) { console.warn('morphonavi a11y', e); }
  };
  new MutationObserver(() => {
    if (!pending) { pending = true; setTimeout(fix, 60); }
  }).observe(document.body, {subtree: true, childList: true, characterData: true});
  fix();
}
"""
"""The page script (JavaScript) described in the module docstring."""


def install_page_a11y(server: Any) -> None:
    """Send :data:`PAGE_SCRIPT` to every page of the viser ``server`` (now and to pages that connect later)."""
    from viser._messages import RunJavascriptMessage

    server.gui._websock_interface.queue_message(RunJavascriptMessage(source=PAGE_SCRIPT))


def element_id(handle: Any) -> str:
    """The DOM id viser gives a GUI element (its button's ``id``): the handle's uuid."""
    return str(handle._impl.uuid)


def hint_spans(hints: Iterable[tuple[Any, str]]) -> str:
    """Hidden HTML that carries each button's hover text to the page script: ``(handle, text)`` pairs."""
    return "".join(f"<span hidden data-mn-hint-for=\"{html.escape(element_id(h))}\" data-mn-hint=\"{html.escape(text)}\">"
                   "</span>" for h, text in hints)


__all__ = ["PAGE_SCRIPT", "element_id", "hint_spans", "install_page_a11y"]
