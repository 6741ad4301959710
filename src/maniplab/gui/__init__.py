"""The browser GUI (``maniplab gui``): configure, simulate, compare and watch an arm on one page,
and the offline HTML replays (:func:`maniplab.gui.player.replay_html`)."""
