"""Short notices, details one click away (console/views/client_notice.py, console/views/notice_details.py):
a capture's long notice is shown as its summary saying where the rest is (a refusal stays whole); its whole text goes once (not once
per tab) to the *Notices: full text* expander of that console, which opens from its folder."""

from __future__ import annotations

from typing import Any

import viser

from console.views import client_notice
from console.views.client_notice import DETAILS_WHERE, SHORT_CHARS, short_body, tell
from console.views.notice_details import FOLDER, NoticeDetails

MAPPED = ("26 objects seen (2 new, 21 updated, 3 not used) in 4.1 s; not used: desk (0.4 m outside the "
          "workspace: not added); chair-2: seen in part along the viewing ray: its centre, a guess from the class "
          "size, not used; cardboard_box-7: buried 0.20 m below the floor (check the camera pose)")


class _Tab:
    def __init__(self, server: Any, client_id: int) -> None:
        self._viser_server, self.client_id, self.open = server, client_id, []

    def add_notification(self, title: str, body: str, *, color: str, auto_close_seconds: Any) -> Any:
        self.open.append((title, body))
        return None


def test_a_long_body_shows_its_summary_and_where_the_rest_is() -> None:
    assert short_body("3 objects seen (3 new) in 1.2 s") is None  # short: shown whole
    assert short_body(MAPPED) == f"26 objects seen (2 new, 21 updated, 3 not used) in 4.1 s … ({DETAILS_WHERE})"
    words = "the robot did not answer the take-off command " * 8  # no "; ": its first words
    cut = short_body(words)
    assert cut is not None and cut.startswith("the robot did not answer") and cut.endswith(f"… ({DETAILS_WHERE})")
    head = cut.split(" … ")[0]
    assert len(head) < SHORT_CHARS and words.startswith(head) and not head.endswith(" ")  # cut between words


def test_the_whole_text_goes_once_to_that_consoles_expander() -> None:
    server = viser.ViserServer(port=0, verbose=False)
    other = viser.ViserServer(port=0, verbose=False)
    try:
        details, elsewhere = NoticeDetails(server), NoticeDetails(other)
        assert details._folder.visible is False  # hidden until there is something to show
        tabs = [_Tab(server, 7101), _Tab(server, 7102)]
        for tab in tabs:  # a broadcast: the same notice in every tab
            tell(tab, "Mapped", MAPPED, "green")
        assert all(tab.open == [("Mapped", short_body(MAPPED))] for tab in tabs)
        assert details.text.count("<b>Mapped</b>") == 1 and elsewhere.text == ""  # another console: not its news
        assert "<li>cardboard_box-7: buried 0.20 m below the floor (check the camera pose)</li>" in details.text
        assert details._folder.visible is True and details._folder.label == FOLDER
        tell(tabs[0], "Mapped", "1 object seen (1 new) in 0.8 s", "green")  # short: nothing more in the expander
        refusal = "Find: 'unicorn' is not an object the perception can name; " + "desk, chair, " * 30
        tell(tabs[0], "Not possible", refusal, "yellow")  # not a capture's report: a reason is shown whole
        assert tabs[0].open[-1] == ("Not possible", refusal) and details.text.count("<b>") == 1
    finally:
        for tab_id in (7101, 7102):
            client_notice.forget(tab_id)
        server.stop()
        other.stop()
