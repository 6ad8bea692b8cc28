"""``loadpath edit``: the load-case editor, a local web page over loadpath's own selector code.

:mod:`.part` reads the part (G-code outlines or STL sections) and lays out what the page draws;
:mod:`.session` answers the page (resolve, solve, save) with :mod:`loadpath.loadcase`;
:mod:`.preview` solves the stress and previews the new paths; :mod:`.server` serves the page
(``static/``, our own HTML/JS/CSS) on 127.0.0.1 with :mod:`loadpath.plugin.localhttp`'s checks.
"""
