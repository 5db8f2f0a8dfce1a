"""Utilities the library itself uses, importing nothing else of the package:

- ``atomic``: outputs that appear whole or not at all (a temporary renamed into place);
- ``pages``: large arrays in bounded memory (chunks, memory-mapped pages let go, sparse zeroed arrays);
- ``figures``: figures read at a glance (readable defaults, a checker of text size, overlaps, clipping).
"""
