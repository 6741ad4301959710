"""Which tab the page shows: viser's tab groups tell the server nothing when the user switches
tabs, so the page's own small script (installed once, from an element of the page) clicks a
hidden button of a button group, named after the tab, whenever a tab is chosen. The server then
clears the tabs' messages and gives each tab its own scene (leaving Watch takes its replay
away and shows the arm being configured again).

The script is a constant of this module: no text from a spec, a run or the page goes into it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

PREFIX = "tab:"
"""The hidden buttons' text: ``tab:Configure``..."""

LABEL = "ml-tab"
"""The hidden button group's label (the script hides its row)."""

_SCRIPT = (
    "var h=function(){Array.prototype.forEach.call(document.querySelectorAll('label'),function(e){"
    "if(e.textContent.trim()==='" + LABEL + "'){var r=e.parentElement;"
    "while(r&&!r.querySelector('button'))r=r.parentElement;if(r)r.style.display='none';}});};"
    "h();if(!window.__mlTabs){window.__mlTabs=1;"
    "new MutationObserver(function(){if(!window.__mlHide){window.__mlHide=setTimeout(function(){"
    "window.__mlHide=0;h();},100);}}).observe(document.body,{childList:true,subtree:true});"
    "document.addEventListener('click',function(ev){"
    "var t=ev.target.closest&&ev.target.closest('[role=tab]');if(!t)return;"
    "var n='" + PREFIX + "'+(t.getAttribute('title')||t.textContent.trim());"
    "setTimeout(function(){var b=Array.prototype.find.call(document.querySelectorAll('button'),"
    "function(x){return x.textContent.trim()===n;});if(b)b.click();},0);},true);}"
)


def tab_watcher(gui: Any, names: Sequence[str], on_switch: Callable[[str], None]) -> Any:
    """Add the hidden button group and the page's script to ``gui`` (a viser GuiApi, in the
    container where they go); ``on_switch(name)`` is called when the page shows tab ``name``.
    Returns the button group."""
    group = gui.add_button_group(LABEL, tuple(PREFIX + n for n in names))
    group.on_click(lambda event: on_switch(str(event.target.value).removeprefix(PREFIX)))
    gui.add_html(f"<img src='data:,' alt='' style='display:none' onerror=\"{_SCRIPT}\">")
    return group
